// The one support header of the tests: bundled models, meshes built in memory, files and
// temporary directories, text helpers, the real psub program run with its streams captured
// (optionally under a timeout), the hostile-input fixture and its file builders, bounding boxes.
// The data paths and the program come from the build (psub_add_test_binary in CMakeLists.txt).
#pragma once

#include "psub/topology.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

namespace psub::test {

// OpenMP's thread count is process-wide: a test that sets it holds one of these, which puts back
// the count it found however the test ends (`found`: to put it back sooner).
struct OmpThreadsRestored {
    const int found = omp_get_max_threads();
    ~OmpThreadsRestored() { omp_set_num_threads(found); }
};

namespace fs = std::filesystem;

// True in AddressSanitizer builds (GCC's and clang's spellings).
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

inline std::string dataPath(const std::string& name) { return std::string(PSUB_DATA) + "/" + name; }
inline std::string testDataPath(const std::string& name) { return std::string(PSUB_TEST_DATA) + "/" + name; }

// Every model the tests refine: bundled ones and the test set (valid meshes only).
inline std::vector<std::string> allValidModels() {
    std::vector<std::string> models = {dataPath("cube.obj"), dataPath("grid4x4.obj"),
                                       dataPath("spot_control_mesh.obj"), dataPath("cow.obj")};
    for (const char* name : {"triangle.obj", "tetrahedron.obj", "suzanne.obj", "bowtie.obj",
                             "mechpart.obj", "double-torus.obj"})
        models.push_back(testDataPath(name));
    for (const char* name :
         {"catmark_cube", "catmark_torus", "catmark_toroidal_tet", "catmark_lefthanded",
          "catmark_tent", "catmark_edgecorner", "catmark_xord_boundary", "catmark_pawn",
          "catmark_pyramid", "catmark_smoothtris0", "catmark_pole64", "catmark_nonquads",
          "catmark_val2_interior", "catmark_nonman_verts"})
        models.push_back(testDataPath(std::string("osd-shapes/") + name + ".obj"));
    return models;
}

struct Loaded {
    Mesh mesh;
    CheckedMesh checked;
};

inline Loaded load(const std::string& path) {
    Loaded loaded{readObj(path), {}};
    loaded.checked = checkMesh(loaded.mesh);
    return loaded;
}

// The message of the InputError that `action` throws; a test failure when it throws none.
template <class Action>
std::string inputErrorOf(Action&& action) {
    try {
        action();
    } catch (const InputError& error) {
        return error.what();
    }
    ADD_FAILURE() << "expected an InputError";
    return "(no error)";
}

// A mesh from literal positions and faces (0-based corners).
inline Mesh makeMesh(std::vector<double> positions,
                     std::initializer_list<std::initializer_list<Index>> faces) {
    Mesh mesh;
    mesh.positions = std::move(positions);
    mesh.faces.vertexCount = Index(mesh.positions.size() / 3);
    for (auto face : faces) mesh.faces.addFace(std::vector<Index>(face));
    return mesh;
}

// An nu x nv quad torus (every vertex regular): vertex (i, j) is j * nu + i, face (i, j) is
// j * nu + i, counter-clockwise.
inline Loaded loadTorus(Index nu, Index nv) {
    Loaded loaded;
    Mesh& mesh = loaded.mesh;
    mesh.faces.vertexCount = nu * nv;
    const double pi = std::numbers::pi;
    for (Index j = 0; j < nv; ++j)
        for (Index i = 0; i < nu; ++i) {
            const double u = 2 * pi * i / nu, v = 2 * pi * j / nv;
            mesh.positions.insert(mesh.positions.end(),
                                  {(3 + std::cos(v)) * std::cos(u), (3 + std::cos(v)) * std::sin(u), std::sin(v)});
            const Index i1 = (i + 1) % nu, j1 = (j + 1) % nv;
            mesh.faces.addFace(std::vector<Index>{j * nu + i, j * nu + i1, j1 * nu + i1, j1 * nu + i});
        }
    loaded.checked = checkMesh(mesh);
    return loaded;
}

// loadTorus(n, n) written to `path` as an OBJ file (for the command-line tests).
inline void writeTorusObj(const std::string& path, Index n) {
    const Loaded torus = loadTorus(n, n);
    std::ofstream out(path);
    for (std::size_t v = 0; v < torus.mesh.positions.size(); v += 3)
        out << "v " << torus.mesh.positions[v] << ' ' << torus.mesh.positions[v + 1] << ' ' << torus.mesh.positions[v + 2] << '\n';
    for (Index f = 0; f < torus.mesh.faces.faceCount(); ++f) {
        out << 'f';
        for (Index v : torus.mesh.faces.face(f)) out << ' ' << v + 1;
        out << '\n';
    }
}

// Frame `frame` of a twisting wave over control points `positions` (xyz triples), `width`
// values per point: xyz, then linear primvars of them (the evaluators' changing frames).
inline std::vector<float> animate(const std::vector<double>& positions, std::uint32_t width, int frame) {
    const std::size_t count = positions.size() / 3;
    std::vector<float> control(count * width);
    for (std::size_t v = 0; v < count; ++v) {
        const double* p = &positions[3 * v];
        const double y = p[1] + 0.1 * std::sin(3 * p[0] + frame);
        for (std::uint32_t i = 0; i < width; ++i)
            control[v * width + i] = float(i == 0 ? p[0] : i == 1 ? y : i == 2 ? p[2] : (i + 1) * p[0] - 0.5 * y + i);
    }
    return control;
}

inline Hierarchy refine(const Loaded& loaded, int steps, Preprocess mode = Preprocess::Auto,
                        Boundary boundary = Boundary::Paper) {
    const bool preprocess = needsPreprocessing(loaded.mesh.faces, loaded.checked.connectivity, mode);
    return refineTopology(loaded.mesh.faces, loaded.checked.connectivity, preprocess, steps, {}, boundary);
}

// Models with a boundary and no non-manifold vertex (where --boundary smooth has work to do
// and OpenSubdiv's boundary rules apply unchanged).
inline std::vector<std::string> manifoldModelsWithBoundary() {
    std::vector<std::string> models;
    for (const std::string& path : allValidModels()) {
        const Loaded loaded = load(path);
        bool nonManifold = false;
        for (VertexKind kind : loaded.checked.connectivity.kind) nonManifold = nonManifold || kind == VertexKind::NonManifold;
        if (loaded.checked.connectivity.boundaryEdgeCount > 0 && !nonManifold) models.push_back(path);
    }
    return models;
}

// ---- Files, text and temporary directories

inline std::string readFile(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline void writeFile(const fs::path& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

// Sorted names in `dir` (hidden ones too, so a left-over temporary shows).
inline std::vector<std::string> namesIn(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

inline bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

inline long countOf(const std::string& text, const std::string& part) {
    long count = 0;
    for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++count;
    return count;
}

inline std::vector<std::string> linesOf(const std::string& text) {
    std::vector<std::string> lines;
    std::size_t start = 0;
    while (start < text.size()) {
        const std::size_t end = text.find('\n', start);
        lines.push_back(text.substr(start, end - start));
        if (end == std::string::npos) break;
        start = end + 1;
    }
    return lines;
}

// `path` in single quotes for the shell (built by append: GCC 12's -Wrestrict misfires on a + chain).
inline std::string quoted(const fs::path& path) {
    std::string text = "'";
    text += path.string();
    text += '\'';
    return text;
}

// A fresh directory under the test temp dir, removed with everything in it at the end of the
// test (after giving its owner back every permission a test took away).
class ScratchDir {
public:
    ScratchDir() {
        std::string pattern = (fs::path(testing::TempDir()) / "psub-test-XXXXXX").string();
        path_ = ::mkdtemp(pattern.data()) ? fs::path(pattern) : fs::path();
        EXPECT_FALSE(path_.empty()) << "mkdtemp failed";
    }
    ~ScratchDir() {
        std::error_code ignored;
        fs::permissions(path_, fs::perms::owner_all, fs::perm_options::add, ignored);
        fs::remove_all(path_, ignored);
    }
    ScratchDir(const ScratchDir&) = delete;
    ScratchDir& operator=(const ScratchDir&) = delete;
    const fs::path& path() const { return path_; }
    fs::path operator/(const std::string& name) const { return path_ / name; }

private:
    fs::path path_;
};

// The length of the diagonal of the bounding box of xyz triples.
inline double boundingDiagonal(const std::vector<double>& p) {
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (std::size_t i = 0; i < p.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], p[i]);
        hi[i % 3] = std::max(hi[i % 3], p[i]);
    }
    return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

// PSUB_ALLOW_NO_VULKAN=1: a test without a Vulkan device (or display) skips instead of failing.
inline bool noVulkanAllowed() {
    const char* allow = std::getenv("PSUB_ALLOW_NO_VULKAN");
    return allow && std::string(allow) == "1";
}

// ---- The psub program

struct PsubRun {
    int status = -1;  // exit status; 124: timed out; 128 + N: killed by signal N
    std::string out, err;
};

// Leak detection off in sanitizer builds (no effect elsewhere): Mesa's lavapipe keeps a few
// allocations until exit. The sanitizer stage preloads lavapipe (scripts/setup.sh), so a child
// that replaces ASAN_OPTIONS must keep ASan's check of the library order off too.
inline constexpr const char* kNoLeakCheck = "ASAN_OPTIONS=detect_leaks=0:verify_asan_link_order=0";

// How runPsub runs psub.
struct PsubHow {
    std::string shellFirst;   // shell commands run first, e.g. "ulimit -v 1048576"
    std::string environment;  // assignments before the program, e.g. "PSUB_VULKAN_VALIDATION=1"
    std::string prefix;       // a program in front of it, e.g. "xvfb-run -a"
    fs::path directory;       // run in this directory; empty: the test's own
    int timeoutSeconds = 0;   // > 0: killed after this long (status 124)
    std::string stdoutTo;     // replaces capturing standard output (e.g. "/dev/full"); out stays empty
};

// `psub ARGS` (shell words) through the shell, standard input empty, both streams captured.
inline PsubRun runPsub(const std::string& args, const PsubHow& how = {}) {
    static std::atomic<int> serial{0};
    const std::string base = (fs::path(testing::TempDir()) / ("psub-run-" + std::to_string(::getpid()) + "-" +
                                                               std::to_string(serial++))).string();
    const std::string out = how.stdoutTo.empty() ? base + ".out" : how.stdoutTo, err = base + ".err";
    std::string command;
    if (!how.directory.empty()) command += "cd " + test::quoted(how.directory) + " && ";
    if (!how.shellFirst.empty()) command += how.shellFirst + " && ";
    command += how.environment + " ";
    if (how.timeoutSeconds > 0) command += "timeout -k 5 " + std::to_string(how.timeoutSeconds) + " ";
    command += how.prefix + " '" PSUB_EXE "' " + args + " >" + test::quoted(out) + " 2>" + test::quoted(err) + " </dev/null";
    const int raw = std::system(command.c_str());
    PsubRun run;
    EXPECT_TRUE(raw != -1 && WIFEXITED(raw)) << command << " (killed by a signal?)";
    if (raw != -1 && WIFEXITED(raw)) run.status = WEXITSTATUS(raw);
    if (how.stdoutTo.empty()) run.out = readFile(out);
    run.err = readFile(err);
    std::error_code ignored;
    if (how.stdoutTo.empty()) fs::remove(out, ignored);
    fs::remove(err, ignored);
    return run;
}

// Runs `psub ARGS` without leak detection; `stdoutTo` as in PsubHow.
inline PsubRun runPsub(const ScratchDir&, const std::string& args, const std::string& stdoutTo = "") {
    PsubHow how;
    how.environment = kNoLeakCheck;
    how.stdoutTo = stdoutTo;
    return runPsub(args, how);
}

// The one stderr line of a failed run; a test failure when there are more or none.
inline std::string oneLine(const PsubRun& run) {
    const std::vector<std::string> lines = linesOf(run.err);
    EXPECT_EQ(lines.size(), 1u) << run.err;
    return lines.empty() ? std::string() : lines.front();
}

// ---- Hostile input: files written here and the fixture that runs psub on them

// One OBJ "v" line per vertex of the unit cube scaled by `scale`, then its six quads.
inline std::string cubeObj(const std::string& scale) {
    std::ostringstream out;
    for (int v = 0; v < 8; ++v)
        out << "v " << ((v & 1) ? "" : "-") << scale << ' ' << ((v & 2) ? "" : "-") << scale << ' '
            << ((v & 4) ? "" : "-") << scale << '\n';
    out << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 2 4 8 6\nf 4 3 7 8\nf 3 1 5 7\n";
    return out.str();
}

// A tetrahedron's buffer: 4 float VEC3 positions (48 bytes), then 12 uint16 indices (24 bytes).
inline std::string tetBin() {
    const float positions[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const std::uint16_t indices[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    std::string bytes(72, '\0');
    std::memcpy(bytes.data(), positions, 48);
    std::memcpy(bytes.data() + 48, indices, 24);
    return bytes;
}

// The tetrahedron as glTF 2.0 JSON over buffer 0 (72 bytes; `buffer` is its JSON object body,
// e.g. "\"uri\": \"tet.bin\", "). The other arguments go in verbatim.
inline std::string tetGltf(const std::string& buffer, const std::string& accessorOffset = "0",
                           const std::string& viewOffset = "0", const std::string& scene = "0",
                           const std::string& more = "") {
    return "{\"asset\": {\"version\": \"2.0\"}, \"scene\": " + scene +
           ", \"scenes\": [{\"nodes\": [0]}], \"nodes\": [{\"mesh\": 0}],\n"
           "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1}]}],\n"
           "\"accessors\": [{\"bufferView\": 0, \"byteOffset\": " + accessorOffset +
           ", \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\", \"min\": [0, 0, 0], \"max\": [1, 1, 1]},\n"
           " {\"bufferView\": 1, \"componentType\": 5123, \"count\": 12, \"type\": \"SCALAR\"}],\n"
           "\"bufferViews\": [{\"buffer\": 0, \"byteOffset\": " + viewOffset + ", \"byteLength\": 48},"
           " {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 24}],\n"
           "\"buffers\": [{" + buffer + "\"byteLength\": 72}]" + more + "}\n";
}

// A .glb of `json` and `bin` chunks with header version `version`.
inline std::string glb(std::string json, const std::string& bin, std::uint32_t version = 2) {
    while (json.size() % 4) json += ' ';
    const auto word = [](std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
    const std::uint32_t total = std::uint32_t(12 + 8 + json.size() + 8 + bin.size());
    return "glTF" + word(version) + word(total) + word(std::uint32_t(json.size())) + "JSON" + json +
           word(std::uint32_t(bin.size())) + std::string("BIN\0", 4) + bin;
}

// A temporary directory per test, files written into it, and the real psub run on them in
// work/ under a timeout (so that a hang fails rather than hangs), with the contract of README
// "Bad input" checked in one place.
class HostileTest : public ::testing::Test {
protected:
    using Run = PsubRun;

    void SetUp() override {
        ASSERT_FALSE(scratch_.path().empty());
        root_ = scratch_.path();
        work_ = root_ / "work";
        fs::create_directory(work_);
    }

    // Writes `content` to work/NAME; returns its path.
    std::string write(const std::string& name, const std::string& content) {
        writeFile(work_ / name, content);
        return path(name);
    }
    std::string path(const std::string& name) const { return (work_ / name).string(); }

    // Every file under work/ with its contents.
    std::map<std::string, std::string> snapshot() const {
        std::map<std::string, std::string> files;
        for (const auto& entry : fs::recursive_directory_iterator(work_)) {
            const fs::path p = entry.path();
            files[p.string()] = entry.is_regular_file() ? readFile(p) : std::string("(not a file)");
        }
        return files;
    }

    // psub ARGS (shell words) run in work/, killed after `seconds`.
    Run psub(const std::string& args, int seconds = 120) {
        PsubHow how;
        how.environment = kNoLeakCheck;
        how.directory = work_;
        how.timeoutSeconds = seconds;
        return runPsub(args, how);
    }

    // The contract for refused input: exit `status`, stderr one line "psub: error: ..." that
    // contains every needle, nothing on stdout, no file added under work/, none changed.
    Run refused(const std::string& args, int status, std::initializer_list<std::string> needles, int seconds = 120) {
        const auto before = snapshot();
        const Run run = psub(args, seconds);
        EXPECT_EQ(run.status, status) << "psub " << args << "\n" << run.err;
        EXPECT_EQ(run.err.rfind("psub: error: ", 0), 0u) << run.err;
        EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
        for (const std::string& needle : needles) EXPECT_TRUE(contains(run.err, needle)) << needle << " not in: " << run.err;
        EXPECT_EQ(run.out, "") << "stdout: " << run.out;
        EXPECT_EQ(snapshot(), before) << "psub " << args << " added or changed a file";
        return run;
    }

    ScratchDir scratch_;
    fs::path root_, work_;
};

}  // namespace psub::test
