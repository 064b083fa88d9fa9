// Shared by the consumer projects: the model refined once, a deformation per frame, and the
// comparison of an evaluator's refined positions with the rule path (psub/rules.h), which
// refines the same control points level by level in double precision.
#pragma once

#include "psub/rules.h"
#include "psub/stencils.h"
#include "psub/topology.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

namespace consumer {

struct Model {
    psub::Mesh mesh;
    psub::Hierarchy hierarchy;  // for the rule path
    psub::Refinement refinement;  // tables for the evaluators
};

inline Model load(const std::string& path, int levels) {
    Model m;
    m.mesh = psub::readObj(path);
    const psub::CheckedMesh checked = psub::checkMesh(m.mesh);
    const bool preprocess = psub::needsPreprocessing(m.mesh.faces, checked.connectivity, psub::Preprocess::Auto);
    m.hierarchy = psub::refineTopology(m.mesh.faces, checked.connectivity, preprocess, levels);
    psub::RefineOptions options;
    options.levels = levels;
    options.factorized = true;
    m.refinement = psub::refine(m.mesh, checked.connectivity, options);
    return m;
}

// Frame `frame`'s control points: a travelling wave over the model's own positions.
inline std::vector<double> deformed(const psub::Mesh& mesh, int frame) {
    std::vector<double> control = mesh.positions;
    for (std::size_t v = 0; v < control.size() / 3; ++v)
        control[3 * v + 1] += 0.05 * std::sin(4 * control[3 * v] + 0.3 * frame);
    return control;
}

// The largest difference from the rule path, relative to the result's bounding-box diagonal;
// printed with `label` when above `tolerance`. True when within it.
inline bool matchesRules(const char* label, int frame, const Model& m, std::span<const double> control,
                         std::span<const float> refined, double tolerance) {
    const std::vector<double> expected = psub::refinePositions(m.hierarchy, control);
    if (expected.size() != refined.size()) {
        std::fprintf(stderr, "%s frame %d: %zu values, the rule path has %zu\n", label, frame, refined.size(),
                     expected.size());
        return false;
    }
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300}, worst = 0;
    for (std::size_t i = 0; i < expected.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], expected[i]);
        hi[i % 3] = std::max(hi[i % 3], expected[i]);
        worst = std::max(worst, std::abs(expected[i] - double(refined[i])));
    }
    const double diagonal = std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    if (!(worst <= tolerance * diagonal)) {
        std::fprintf(stderr, "%s frame %d: differs from the rule path by %g (diagonal %g)\n", label, frame, worst,
                     diagonal);
        return false;
    }
    return true;
}

inline std::vector<float> toFloat(std::span<const double> values) { return {values.begin(), values.end()}; }

}  // namespace consumer
