// P-S against Catmull-Clark on whole meshes: volume, area, bounding box and sampled two-sided
// Hausdorff distance (nearest points on triangles through a kd-tree of their bounding boxes).
#include "psub/analysis.h"
#include "psub/catmark.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"

#include <omp.h>
#include <Eigen/Geometry>
#include <unsupported/Eigen/BVH>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace psub {
namespace {

using Vec = std::array<double, 3>;

Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec cross(const Vec& a, const Vec& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec point(std::span<const double> p, Index v) { return {p[3 * v], p[3 * v + 1], p[3 * v + 2]}; }

// Faces fan-triangulated from their first corner: 3 vertex indices per triangle.
std::vector<Index> triangulate(const Faces& faces) {
    std::vector<Index> out;
    for (Index f = 0; f < faces.faceCount(); ++f) {
        const auto c = faces.face(f);
        for (std::size_t i = 1; i + 1 < c.size(); ++i) out.insert(out.end(), {c[0], c[i], c[i + 1]});
    }
    return out;
}

// Squared distance from p to triangle abc (Ericson, Real-Time Collision Detection, 5.1.5).
double squaredDistanceToTriangle(const Vec& p, const Vec& a, const Vec& b, const Vec& c) {
    const Vec ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
    const auto at = [&](double v, double w) {
        const Vec q{a[0] + ab[0] * v + ac[0] * w, a[1] + ab[1] * v + ac[1] * w, a[2] + ab[2] * v + ac[2] * w};
        const Vec d = sub(p, q);
        return dot(d, d);
    };
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return dot(ap, ap);
    const Vec bp = sub(p, b);
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return dot(bp, bp);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return at(d1 / (d1 - d3), 0);
    const Vec cp = sub(p, c);
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return dot(cp, cp);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return at(0, d2 / (d2 - d6));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return at(1 - w, w);  // on edge bc
    }
    const double denominator = 1 / (va + vb + vc);
    return at(vb * denominator, vc * denominator);
}

// A triangle set in Eigen's kd-tree of bounding boxes (unsupported/Eigen/BVH: median splits
// of the boxes' centres), searched best first for the nearest triangle. Median splits keep the
// cost per query logarithmic however the triangles are spread: a far outlier vertex or two
// distant clusters cost a few levels of the tree, where a uniform grid over the bounding box
// put every other triangle into one cell and made the search quadratic.
class TriangleTree {
public:
    using Box = Eigen::AlignedBox<double, 3>;

    TriangleTree(std::span<const double> positions, std::vector<Index> triangles)
        : positions_(positions), triangles_(std::move(triangles)) {
        const std::size_t count = triangles_.size() / 3;
        std::vector<std::uint32_t> ids(count);
        std::vector<Box> boxes(count);
        double area = 0, largest = 0;
        for (std::size_t t = 0; t < count; ++t) {
            const Vec a = corner(t, 0), b = corner(t, 1), c = corner(t, 2);
            const Vec n = cross(sub(b, a), sub(c, a));
            area += std::hypot(n[0], n[1], n[2]) / 2;  // hypot: no overflow in the squares
            for (const Vec& v : {a, b, c}) {
                boxes[t].extend(Eigen::Vector3d(v[0], v[1], v[2]));
                largest = std::max({largest, std::abs(v[0]), std::abs(v[1]), std::abs(v[2])});
            }
            ids[t] = std::uint32_t(t);
        }
        // The point-triangle test multiplies dot products of coordinate differences (up to
        // 2 * largest each): about 150 * largest^4 must stay finite, so coordinates beyond
        // about 1e75 (compare's input limit, 1e60, keeps them out) would give NaN: refuse them.
        const double square = 12 * largest * largest;
        if (!std::isfinite(area) || !std::isfinite(square * square))
            throw std::invalid_argument("surfaceDistances: coordinates too large (beyond 1e75 the distance test overflows) or not finite");
        tree_.init(ids.begin(), ids.end(), boxes.begin(), boxes.end());
    }

    // Distance from p to the nearest triangle (NaN for a non-finite p).
    double distance(const Vec& p) const {
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
            return std::numeric_limits<double>::quiet_NaN();
        Nearest nearest{this, p, Eigen::Vector3d(p[0], p[1], p[2])};
        return std::sqrt(Eigen::BVMinimize(tree_, nearest));
    }

private:
    // Eigen's minimizer interface: squared distances to a box and to a triangle.
    struct Nearest {
        using Scalar = double;
        const TriangleTree* tree;
        Vec p;
        Eigen::Vector3d q;
        double minimumOnVolume(const Box& box) const { return box.squaredExteriorDistance(q); }
        double minimumOnObject(std::uint32_t t) const {
            return squaredDistanceToTriangle(p, tree->corner(t, 0), tree->corner(t, 1), tree->corner(t, 2));
        }
    };

    Vec corner(std::size_t t, int k) const { return point(positions_, triangles_[3 * t + std::size_t(k)]); }

    std::span<const double> positions_;
    std::vector<Index> triangles_;
    Eigen::KdBVH<double, 3, std::uint32_t> tree_;
};

}  // namespace

double MeshMeasures::diagonal() const {
    const Vec d = sub(hi, lo);
    return std::sqrt(dot(d, d));
}

MeshMeasures measureMesh(const Faces& faces, std::span<const double> positions) {
    MeshMeasures m;
    m.lo = {1e300, 1e300, 1e300};
    m.hi = {-1e300, -1e300, -1e300};
    const std::vector<Index> triangles = triangulate(faces);
    for (std::size_t t = 0; t < triangles.size(); t += 3) {
        const Vec a = point(positions, triangles[t]), b = point(positions, triangles[t + 1]),
                  c = point(positions, triangles[t + 2]);
        m.volume += dot(a, cross(b, c)) / 6;
        const Vec n = cross(sub(b, a), sub(c, a));
        m.area += std::hypot(n[0], n[1], n[2]) / 2;  // hypot: no overflow in the squares
    }
    for (Index v : faces.verts)
        for (std::size_t a = 0; a < 3; ++a) {
            m.lo[a] = std::min(m.lo[a], positions[3 * v + a]);
            m.hi[a] = std::max(m.hi[a], positions[3 * v + a]);
        }
    return m;
}

std::vector<double> surfaceDistances(const Faces& from, std::span<const double> fromPositions,
                                     const Faces& to, std::span<const double> toPositions, int samplesPerEdge) {
    if (samplesPerEdge < 1 || from.faceCount() == 0 || to.faceCount() == 0)
        throw std::invalid_argument("surfaceDistances: samplesPerEdge >= 1 and faces on both meshes");
    const TriangleTree tree(toPositions, triangulate(to));
    const std::vector<Index> sources = triangulate(from);
    const int m = samplesPerEdge;
    const std::size_t perTriangle = std::size_t(m + 1) * std::size_t(m + 2) / 2;
    const std::size_t triangles = sources.size() / 3;
    std::vector<double> out(triangles * perTriangle);
#pragma omp parallel for schedule(dynamic, 256)
        for (std::size_t t = 0; t < triangles; ++t) {
            const Vec a = point(fromPositions, sources[3 * t]), b = point(fromPositions, sources[3 * t + 1]),
                      c = point(fromPositions, sources[3 * t + 2]);
            std::size_t k = t * perTriangle;
            for (int i = 0; i <= m; ++i)
                for (int j = 0; i + j <= m; ++j) {
                    const double u = double(i) / m, v = double(j) / m, w = 1 - u - v;
                    const Vec p{w * a[0] + u * b[0] + v * c[0], w * a[1] + u * b[1] + v * c[1],
                                w * a[2] + u * b[2] + v * c[2]};
                    out[k++] = tree.distance(p);
                }
        }
    return out;
}

double Fidelity::hausdorff() const {
    double worst = 0;
    for (double d : psToCc) worst = std::max(worst, d);
    for (double d : ccToPs) worst = std::max(worst, d);
    return worst;
}

double Fidelity::meanDistance() const {
    double sum = 0;
    for (double d : psToCc) sum += d;
    for (double d : ccToPs) sum += d;
    const std::size_t count = psToCc.size() + ccToPs.size();
    return count ? sum / double(count) : 0;
}

namespace {

// Fidelity::evNormalSpreads of a P-S result.
std::vector<double> extraordinaryNormalSpreads(const Faces& faces, std::span<const double> p) {
    const Connectivity c = buildConnectivity(faces);
    std::vector<std::vector<std::array<double, 3>>> normals(faces.vertexCount);
    for (Index v = 0; v < faces.vertexCount; ++v)
        if (c.kind[v] == VertexKind::Interior && c.valence[v] != 4) normals[v].reserve(c.valence[v]);
    for (Index f = 0; f < faces.faceCount(); ++f) {
        const auto corners = faces.face(f);
        std::array<double, 3> n{0, 0, 0};  // Newell's normal
        for (std::size_t k = 0; k < corners.size(); ++k) {
            const double* a = &p[3 * std::size_t(corners[k])];
            const double* b = &p[3 * std::size_t(corners[(k + 1) % corners.size()])];
            n[0] += (a[1] - b[1]) * (a[2] + b[2]);
            n[1] += (a[2] - b[2]) * (a[0] + b[0]);
            n[2] += (a[0] - b[0]) * (a[1] + b[1]);
        }
        const double length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (length > 0)
            for (double& x : n) x /= length;
        for (Index v : corners)
            if (normals[v].capacity() > 0) normals[v].push_back(n);
    }
    std::vector<double> out;
    for (const auto& around : normals) {
        if (around.empty()) continue;
        double lowest = 1;
        for (std::size_t a = 0; a < around.size(); ++a)
            for (std::size_t b = a + 1; b < around.size(); ++b)
                lowest = std::min(lowest, around[a][0] * around[b][0] + around[a][1] * around[b][1] + around[a][2] * around[b][2]);
        out.push_back(std::acos(std::clamp(lowest, -1.0, 1.0)) * 180 / std::numbers::pi);
    }
    return out;
}

}  // namespace

Fidelity compareWithCatmark(const Mesh& mesh, const Connectivity& connectivity, int psSteps, Rules rules,
                            int samplesPerEdge, Boundary boundary) {
    if (psSteps < 0 || psSteps % 2 != 0 || samplesPerEdge < 0)
        throw std::invalid_argument("compareWithCatmark: psSteps even and >= 0, samplesPerEdge >= 0");
    Fidelity out;
    out.psSteps = psSteps;
    out.ccLevels = psSteps / 2;
    out.input = measureMesh(mesh.faces, mesh.positions);

    RefineOptions options;
    options.levels = psSteps;
    options.rules = rules;
    options.boundary = boundary;
    const Refinement refinement = refine(mesh, connectivity, options);
    CpuEvaluator<double> evaluator(refinement.perLevel, refinement.factorized, refinement.surface, TableForm::PerLevel);
    std::vector<double> ps(3 * std::size_t(evaluator.refinedCount()));
    evaluator.evaluate(mesh.positions, ps);
    Faces psFaces;
    psFaces.vertexCount = refinement.surface.vertexCount;
    psFaces.offsets = refinement.surface.faceOffsets;
    psFaces.verts = refinement.surface.faceVerts;

    out.evNormalSpreads = extraordinaryNormalSpreads(psFaces, ps);

    const std::vector<CatmarkLevel> cc = refineCatmark(mesh.faces, mesh.positions, out.ccLevels);
    const CatmarkLevel& finest = cc.back();
    out.psFaces = psFaces.faceCount();
    out.ccFaces = finest.faces.faceCount();
    out.ps = measureMesh(psFaces, ps);
    out.cc = measureMesh(finest.faces, finest.positions);
    if (samplesPerEdge == 0) return out;
    out.psToCc = surfaceDistances(psFaces, ps, finest.faces, finest.positions, samplesPerEdge);
    out.ccToPs = surfaceDistances(finest.faces, finest.positions, psFaces, ps, samplesPerEdge);
    return out;
}

}  // namespace psub
