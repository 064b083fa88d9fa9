// The boundary triangles' shape per level under each boundary mode: how thin the paper's
// never-refined boundary makes them, and what Boundary::Smooth does about it.
#include "psub/analysis.h"
#include "psub/stencils.h"

#include <algorithm>
#include <cmath>

namespace psub {
namespace {

double distance(std::span<const double> p, Index a, Index b) {
    return std::hypot(p[3 * a] - p[3 * b], p[3 * a + 1] - p[3 * b + 1], p[3 * a + 2] - p[3 * b + 2]);
}

// Longest edge over the height on it (1.155 for an equilateral triangle); infinite when flat.
// The area from the cross product: Heron's formula loses digits on thin triangles.
double triangleAspect(std::span<const double> p, Index a, Index b, Index c) {
    double u[3], v[3];
    for (int i = 0; i < 3; ++i) u[i] = p[3 * b + i] - p[3 * a + i], v[i] = p[3 * c + i] - p[3 * a + i];
    const double area = std::hypot(u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]) / 2;
    const double longest = std::max({distance(p, a, b), distance(p, b, c), distance(p, c, a)});
    return area > 0 ? longest * longest / (2 * area) : INFINITY;
}

}  // namespace

BoundaryAspect boundaryTriangleAspect(const Faces& faces, const Connectivity& connectivity,
                                      std::span<const double> positions) {
    std::vector<double> aspects;
    for (Index f = 0; f < faces.faceCount(); ++f) {
        if (faces.faceSize(f) != 3) continue;
        bool onBoundary = false;
        for (Index h = faces.offsets[f]; h < faces.offsets[f + 1]; ++h)
            onBoundary = onBoundary || connectivity.twin[h] == kNoIndex;
        if (!onBoundary) continue;
        const auto corners = faces.face(f);
        aspects.push_back(triangleAspect(positions, corners[0], corners[1], corners[2]));
    }
    BoundaryAspect out;
    out.triangles = aspects.size();
    if (aspects.empty()) return out;
    std::sort(aspects.begin(), aspects.end());
    out.worst = aspects.back();
    out.median = aspects[aspects.size() / 2];
    return out;
}

std::vector<BoundaryAspect> boundaryAspectByLevel(const Mesh& mesh, const Connectivity& connectivity,
                                                  int psSteps, Boundary boundary, Rules rules) {
    const bool preprocess = needsPreprocessing(mesh.faces, connectivity, Preprocess::Auto, mesh.source);
    const Hierarchy hierarchy = refineTopology(mesh.faces, connectivity, preprocess, psSteps, {}, boundary);
    std::vector<double> positions = mesh.positions;
    std::vector<BoundaryAspect> out;
    for (std::size_t k = 1; k < hierarchy.levels.size(); ++k) {
        positions = refineLevelPositions(hierarchy, k, positions, rules);
        if (preprocess && k == 1) continue;  // levels count P-S steps
        const Level& level = hierarchy.levels[k];
        out.push_back(boundaryTriangleAspect(level.faces, level.connectivity, positions));
    }
    return out;
}

}  // namespace psub
