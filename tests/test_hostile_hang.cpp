// Class 2 of the hostile inputs: what hung psub. A glTF buffer or image URI naming a FIFO (or
// any file that is not regular: directory, device) is refused by stat before anything opens
// it; compare's nearest-triangle search stays fast when one vertex lies far from the rest.
// Each run has a timeout, so a hang fails the test instead of hanging it.
#include "test_support.h"

#include "psub/analysis.h"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <sstream>

namespace psub::test {
namespace {

class HostileHang : public HostileTest {
protected:
    // play on a glTF whose buffer 0 is `uri`; 30 s is far more than a refusal takes.
    Run playWithBuffer(const std::string& uri, int status, std::initializer_list<std::string> needles) {
        write("tet.gltf", tetGltf("\"uri\": \"" + uri + "\", "));
        return refused("play tet.gltf --frames 2 --levels 1", status, needles, 30);
    }
};

TEST_F(HostileHang, TheFixtureWithARegularBufferPlays) {
    write("tet.bin", tetBin());
    write("tet.gltf", tetGltf("\"uri\": \"tet.bin\", "));
    const Run run = psub("play tet.gltf --frames 2 --levels 1", 60);
    EXPECT_EQ(run.status, 0) << run.err;
}

TEST_F(HostileHang, BufferUriNamingAFifoIsRefusedWithoutBlocking) {
    ASSERT_EQ(::mkfifo(path("pipe.bin").c_str(), 0600), 0);
    playWithBuffer("pipe.bin", 1, {"tet.gltf: buffer 0: uri 'pipe.bin'", "named pipe (FIFO), not a regular file"});
}

TEST_F(HostileHang, BufferUriNamingAFifoInPercentEncodingIsRefused) {
    ASSERT_EQ(::mkfifo(path("a pipe.bin").c_str(), 0600), 0);
    playWithBuffer("a%20pipe.bin", 1, {"buffer 0", "named pipe (FIFO)"});
}

TEST_F(HostileHang, ImageUriNamingAFifoIsRefusedWithoutBlocking) {
    write("tet.bin", tetBin());
    ASSERT_EQ(::mkfifo(path("pipe.png").c_str(), 0600), 0);
    write("tet.gltf", tetGltf("\"uri\": \"tet.bin\", ", "0", "0", "0", ", \"images\": [{\"uri\": \"pipe.png\"}]"));
    refused("play tet.gltf --frames 2 --levels 1", 1, {"tet.gltf: image 0: uri 'pipe.png'", "named pipe"}, 30);
}

TEST_F(HostileHang, BufferUriNamingADirectoryIsRefusedNotOutOfMemory) {
    fs::create_directory(work_ / "dir.bin");
    playWithBuffer("dir.bin", 1, {"tet.gltf: buffer 0: uri 'dir.bin'", "is a directory"});
}

TEST_F(HostileHang, BufferUriNamingACharacterDeviceIsRefused) {
    playWithBuffer("/dev/zero", 1, {"tet.gltf: buffer 0: uri '/dev/zero'", "character device"});
}

TEST_F(HostileHang, BufferFileOfTheWrongSizeIsRefusedBeforeReading) {
    write("big.bin", tetBin() + std::string(1 << 20, '\0'));
    playWithBuffer("big.bin", 1, {"tet.gltf: buffer 0: uri 'big.bin'", "1048648 bytes, byteLength says 72"});
}

// The cow with its first vertex moved 491915 units away (a fuzzer's finding): a uniform grid
// over the bounding box put the whole cow into one cell, so every sample point scanned every
// triangle and compare ran for minutes (more than 120 s; the cow itself takes about 1 s).
TEST_F(HostileHang, CompareWithOneFarOutlierVertexFinishes) {
    std::ifstream in(dataPath("cow.obj"));
    std::stringstream text;
    std::string line;
    bool moved = false;
    while (std::getline(in, line)) {
        if (!moved && line.rfind("v ", 0) == 0) line = "v -491915 0 0", moved = true;
        text << line << "\n";
    }
    ASSERT_TRUE(moved);
    write("outlier.obj", text.str());
    const Run run = psub("compare outlier.obj --json", 120);
    ASSERT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(contains(run.out, "\"hausdorff\"")) << run.out;
}

// Distance from p to triangle abc, computed independently of the library: the projection onto
// the plane when it falls inside (barycentric coordinates from cross products), else the nearest
// of the three edges (clamped projection onto each segment).
double referenceDistance(const std::array<double, 3>& p, const std::array<double, 3>& a,
                         const std::array<double, 3>& b, const std::array<double, 3>& c) {
    const auto sub = [](auto x, auto y) { return std::array<double, 3>{x[0] - y[0], x[1] - y[1], x[2] - y[2]}; };
    const auto dot = [](auto x, auto y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
    const auto segment = [&](auto s, auto e) {
        const auto d = sub(e, s);
        const double t = std::clamp(dot(sub(p, s), d) / dot(d, d), 0.0, 1.0);
        const std::array<double, 3> q{s[0] + t * d[0], s[1] + t * d[1], s[2] + t * d[2]};
        return std::sqrt(dot(sub(p, q), sub(p, q)));
    };
    const auto cross = [](auto x, auto y) {
        return std::array<double, 3>{x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]};
    };
    // Cramer's rule through cross products (no difference of two huge products, which loses
    // everything on the outlier's slivers): s = (w x v).n / n.n, t = (u x w).n / n.n.
    const auto u = sub(b, a), v = sub(c, a), w = sub(p, a), n = cross(u, v);
    const double s = dot(cross(w, v), n) / dot(n, n), t = dot(cross(u, w), n) / dot(n, n);
    if (s >= 0 && t >= 0 && s + t <= 1) {
        const std::array<double, 3> q{a[0] + s * u[0] + t * v[0], a[1] + s * u[1] + t * v[1], a[2] + s * u[2] + t * v[2]};
        return std::sqrt(dot(sub(p, q), sub(p, q)));
    }
    return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

// The library's nearest-triangle search against a scan of every triangle, on meshes whose
// triangles are spread the way that defeated the grid: a far outlier vertex, and two clusters
// far apart. Sample points are the same barycentric grid surfaceDistances uses.
TEST(HostileHangLibrary, NearestTriangleSearchEqualsAFullScanOnSpreadOutMeshes) {
    // A 6 x 6 grid of unit quads (fan-split into triangles by the library), then variations.
    const auto grid = [](double xOffset) {
        Mesh m;
        m.faces.vertexCount = 49;
        for (int j = 0; j < 7; ++j)
            for (int i = 0; i < 7; ++i) m.positions.insert(m.positions.end(), {xOffset + i, double(j), 0.1 * ((i * j) % 3)});
        for (int j = 0; j < 6; ++j)
            for (int i = 0; i < 6; ++i)
                m.faces.addFace(std::vector<Index>{Index(7 * j + i), Index(7 * j + i + 1), Index(7 * j + i + 8), Index(7 * j + i + 7)});
        return m;
    };
    Mesh outlier = grid(0);
    outlier.positions[3 * 24] = -491915;  // the centre vertex, far along -x
    Mesh clusters = grid(0);
    const Mesh far = grid(1e7);
    for (Index f = 0; f < far.faces.faceCount(); ++f) {
        std::vector<Index> corners;
        for (Index v : far.faces.face(f)) corners.push_back(v + 49);
        clusters.faces.addFace(corners);
    }
    clusters.faces.vertexCount = 98;
    clusters.positions.insert(clusters.positions.end(), far.positions.begin(), far.positions.end());
    const Mesh plain = grid(0.5);

    const auto corner = [](const Mesh& m, Index v) {
        return std::array<double, 3>{m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
    };
    const int samples = 3;
    using Pair = std::array<const Mesh*, 2>;
    for (const Pair& pair : {Pair{&plain, &outlier}, Pair{&outlier, &plain}, Pair{&plain, &clusters}, Pair{&clusters, &outlier}}) {
        const Mesh& from = *pair[0];
        const Mesh& to = *pair[1];
        const std::vector<double> d = surfaceDistances(from.faces, from.positions, to.faces, to.positions, samples);
        std::size_t k = 0;
        for (Index f = 0; f < from.faces.faceCount(); ++f) {
            const auto c = from.faces.face(f);
            for (std::size_t t = 1; t + 1 < c.size(); ++t)  // the library's fan from the first corner
                for (int i = 0; i <= samples; ++i)
                    for (int j = 0; i + j <= samples; ++j) {
                        const double u = double(i) / samples, v = double(j) / samples, w = 1 - u - v;
                        const auto a = corner(from, c[0]), b = corner(from, c[t]), e = corner(from, c[t + 1]);
                        const std::array<double, 3> p{w * a[0] + u * b[0] + v * e[0], w * a[1] + u * b[1] + v * e[1],
                                                      w * a[2] + u * b[2] + v * e[2]};
                        double best = INFINITY;
                        for (Index g = 0; g < to.faces.faceCount(); ++g) {
                            const auto q = to.faces.face(g);
                            for (std::size_t s = 1; s + 1 < q.size(); ++s)
                                best = std::min(best, referenceDistance(p, corner(to, q[0]), corner(to, q[s]), corner(to, q[s + 1])));
                        }
                        ASSERT_LT(k, d.size());
                        // Relative to the largest coordinate (1e7 in the clusters): rounding of
                        // two different formulas, nothing more.
                        EXPECT_NEAR(d[k], best, 1e-9 * std::max(1.0, best) + 1e-6) << "sample " << k;
                        ++k;
                    }
        }
        EXPECT_EQ(k, d.size());
    }
}

}  // namespace
}  // namespace psub::test
