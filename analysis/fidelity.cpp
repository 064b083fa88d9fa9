// P-S against Catmull-Clark on whole meshes: volume, area, bounding box and sampled two-sided
// Hausdorff distance (nearest points on triangles through a uniform grid of cells).
#include "psub/analysis.h"
#include "psub/catmark.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"

#include <omp.h>

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

// A uniform grid of cells over a triangle set; each triangle listed in every cell its bounding
// box touches. About one triangle per cell.
class TriangleGrid {
public:
    TriangleGrid(std::span<const double> positions, std::vector<Index> triangles)
        : positions_(positions), triangles_(std::move(triangles)) {
        const std::size_t count = triangles_.size() / 3;
        lo_ = {1e300, 1e300, 1e300};
        Vec hi{-1e300, -1e300, -1e300};
        for (Index v : triangles_)
            for (int a = 0; a < 3; ++a) {
                lo_[std::size_t(a)] = std::min(lo_[std::size_t(a)], positions_[3 * v + std::size_t(a)]);
                hi[std::size_t(a)] = std::max(hi[std::size_t(a)], positions_[3 * v + std::size_t(a)]);
            }
        Vec extent = sub(hi, lo_);
        const double largest = std::max({extent[0], extent[1], extent[2], 1e-30});
        for (double& e : extent) e = std::max(e, largest * 1e-3);
        // Cells about twice a typical triangle's size (from the total area), so that a cell
        // the surface crosses holds a few triangles; at most 4 cells per triangle (plus 2^20).
        double area = 0;
        for (std::size_t t = 0; t < count; ++t) {
            const Vec a = point(positions_, triangles_[3 * t]), b = point(positions_, triangles_[3 * t + 1]),
                      c = point(positions_, triangles_[3 * t + 2]);
            const Vec n = cross(sub(b, a), sub(c, a));
            area += std::hypot(n[0], n[1], n[2]) / 2;  // hypot: no overflow in the squares
        }
        // Coordinates beyond the range that squares and areas fit in (compare's input limit
        // keeps them out) would make the cell size or an index NaN: refuse them here.
        if (!std::isfinite(area) || !std::isfinite(largest))
            throw std::invalid_argument("surfaceDistances: coordinates too large (their squares overflow) or not finite");
        const double maxCells = 4.0 * double(count) + double(1 << 20);
        double cell = 2 * std::sqrt(area / double(std::max<std::size_t>(count, 1)));
        cell = std::max({cell, std::cbrt(extent[0] * extent[1] * extent[2] / maxCells), largest / 2048});
        for (int a = 0; a < 3; ++a) {
            dims_[a] = int(std::clamp(std::ceil(extent[std::size_t(a)] / cell), 1.0, 2048.0));
            size_[std::size_t(a)] = extent[std::size_t(a)] / dims_[a];
        }
        // Two passes: count per cell, then fill (compressed rows).
        offsets_.assign(std::size_t(dims_[0]) * std::size_t(dims_[1]) * std::size_t(dims_[2]) + 1, 0);
        for (int pass = 0; pass < 2; ++pass) {
            std::vector<std::uint32_t> fill;
            if (pass == 1) {
                for (std::size_t c = 1; c < offsets_.size(); ++c) offsets_[c] += offsets_[c - 1];
                items_.resize(offsets_.back());
                fill.assign(offsets_.begin(), offsets_.end() - 1);
            }
            for (std::size_t t = 0; t < count; ++t) {
                int from[3], to[3];
                for (int a = 0; a < 3; ++a) {
                    double l = 1e300, h = -1e300;
                    for (int k = 0; k < 3; ++k) {
                        const double x = positions_[3 * triangles_[3 * t + std::size_t(k)] + std::size_t(a)];
                        l = std::min(l, x);
                        h = std::max(h, x);
                    }
                    from[a] = cellIndex(a, l);
                    to[a] = cellIndex(a, h);
                }
                for (int z = from[2]; z <= to[2]; ++z)
                    for (int y = from[1]; y <= to[1]; ++y)
                        for (int x = from[0]; x <= to[0]; ++x) {
                            const std::size_t c = cellOf(x, y, z);
                            if (pass == 0)
                                ++offsets_[c + 1];
                            else
                                items_[fill[c]++] = std::uint32_t(t);
                        }
            }
        }
    }

    std::size_t triangleCount() const { return triangles_.size() / 3; }

    // Distance from p to the nearest triangle. `stamp` (triangleCount() entries, owned by the
    // calling thread) and `query` (a number unique per call on that thread) skip repeats.
    double distance(const Vec& p, std::vector<std::uint32_t>& stamp, std::uint32_t query) const {
        const int c[3] = {cellIndex(0, p[0]), cellIndex(1, p[1]), cellIndex(2, p[2])};
        double best = std::numeric_limits<double>::infinity();
        const int reach = std::max({dims_[0], dims_[1], dims_[2]});
        for (int r = 0; r <= reach; ++r) {
            for (int z = c[2] - r; z <= c[2] + r; ++z) {
                if (z < 0 || z >= dims_[2]) continue;
                for (int y = c[1] - r; y <= c[1] + r; ++y) {
                    if (y < 0 || y >= dims_[1]) continue;
                    const bool faceZY = std::abs(z - c[2]) == r || std::abs(y - c[1]) == r;
                    for (int x = c[0] - r; x <= c[0] + r; x += (faceZY || r == 0) ? 1 : 2 * r) {
                        if (x < 0 || x >= dims_[0]) continue;
                        const std::size_t cell = cellOf(x, y, z);
                        for (std::uint64_t e = offsets_[cell]; e < offsets_[cell + 1]; ++e) {
                            const std::uint32_t t = items_[e];
                            if (stamp[t] == query) continue;
                            stamp[t] = query;
                            const Index* v = &triangles_[3 * std::size_t(t)];
                            best = std::min(best, squaredDistanceToTriangle(p, point(positions_, v[0]),
                                                                            point(positions_, v[1]), point(positions_, v[2])));
                        }
                    }
                }
            }
            // Triangles not met yet lie only in cells outside the box of cells c-r..c+r.
            double bound = std::numeric_limits<double>::infinity();
            for (int a = 0; a < 3; ++a) {
                const std::size_t u = std::size_t(a);
                if (c[a] - r > 0) bound = std::min(bound, p[u] - (lo_[u] + (c[a] - r) * size_[u]));
                if (c[a] + r < dims_[a] - 1) bound = std::min(bound, lo_[u] + (c[a] + r + 1) * size_[u] - p[u]);
            }
            if (bound == std::numeric_limits<double>::infinity() || best <= bound * bound) break;
        }
        return std::sqrt(best);
    }

private:
    int cellIndex(int axis, double x) const {
        const double t = (x - lo_[std::size_t(axis)]) / size_[std::size_t(axis)];
        if (!(t > 0)) return 0;  // also NaN (a non-finite sample point): never an index from it
        return int(std::min(std::floor(t), double(dims_[axis] - 1)));
    }
    std::size_t cellOf(int x, int y, int z) const {
        return (std::size_t(z) * std::size_t(dims_[1]) + std::size_t(y)) * std::size_t(dims_[0]) + std::size_t(x);
    }

    std::span<const double> positions_;
    std::vector<Index> triangles_;
    Vec lo_{}, size_{};
    int dims_[3] = {1, 1, 1};
    std::vector<std::uint64_t> offsets_;
    std::vector<std::uint32_t> items_;
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
    const TriangleGrid grid(toPositions, triangulate(to));
    const std::vector<Index> sources = triangulate(from);
    const int m = samplesPerEdge;
    const std::size_t perTriangle = std::size_t(m + 1) * std::size_t(m + 2) / 2;
    const std::size_t triangles = sources.size() / 3;
    std::vector<double> out(triangles * perTriangle);
#pragma omp parallel
    {
        std::vector<std::uint32_t> stamp(grid.triangleCount(), 0);
        std::uint32_t query = 0;
#pragma omp for schedule(dynamic, 256)
        for (std::size_t t = 0; t < triangles; ++t) {
            const Vec a = point(fromPositions, sources[3 * t]), b = point(fromPositions, sources[3 * t + 1]),
                      c = point(fromPositions, sources[3 * t + 2]);
            std::size_t k = t * perTriangle;
            for (int i = 0; i <= m; ++i)
                for (int j = 0; i + j <= m; ++j) {
                    const double u = double(i) / m, v = double(j) / m, w = 1 - u - v;
                    const Vec p{w * a[0] + u * b[0] + v * c[0], w * a[1] + u * b[1] + v * c[1],
                                w * a[2] + u * b[2] + v * c[2]};
                    if (++query == 0) std::fill(stamp.begin(), stamp.end(), 0), query = 1;
                    out[k++] = grid.distance(p, stamp, query);
                }
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
