// psub/rules.h: SPEC.md's geometric rules, stated once (the weights c,d,e and f,g,h) and
// applied the plain way, level by level, to xyz positions. This readable path is the
// engine's oracle for the table-driven evaluators; keep it obviously correct, not fast.
#pragma once

#include "psub/topology.h"

#include <span>
#include <vector>

namespace psub {

// Weights of an interior V-vertex: centre P, each edge neighbour Pi, each diagonal Pj.
struct VertexWeights {
    double centre, edge, diagonal;
};

// All incident faces quads: c = (n-3)/n, d = 2/n^2, e = 1/n^2 (n = valence).
VertexWeights quadVertexWeights(Index n);

// At least one incident triangle: f = 1/(1 + n/2 + m/4), g = f/2, h = f/4 (m = quads).
VertexWeights mixedVertexWeights(Index n, Index m);

// True for vertices whose V-vertex keeps its position: boundary, non-manifold, unused.
inline bool isRetained(VertexKind kind) { return kind != VertexKind::Interior; }

// The paired method's positions: old vertices unchanged, then each face's centroid.
std::vector<double> pairedPositions(const Faces& faces, std::span<const double> positions);

// One P-S step's positions: V-vertices by the rules above, then F-vertices (face averages).
// The mesh must be P-S input (quads, triangles only on the boundary).
std::vector<double> psPositions(const Faces& faces, const Connectivity& connectivity,
                                std::span<const double> positions);

// Positions of hierarchy.levels[k] from those of levels[k-1] (paired method or P-S step).
std::vector<double> refineLevelPositions(const Hierarchy& hierarchy, std::size_t k,
                                         std::span<const double> parentPositions);

// Positions of the finest level of `hierarchy` from the control positions of levels[0].
std::vector<double> refinePositions(const Hierarchy& hierarchy, std::span<const double> control);

}  // namespace psub
