// psub/rules.h: the geometric rules of docs/scheme.md, stated once (the weights c,d,e and f,g,h) and
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

// Which rules a refinement follows. Paper: docs/scheme.md exactly (the default everywhere).
// Robust (beyond the paper, never the default): the same, except that an interior vertex of
// valence 2 with both faces quads gets c, d, e = 0, 1/3, 1/6, where the paper's c = -1/2
// folds the two faces back to back.
enum class Rules { Paper, Robust };

// "paper" or "robust".
const char* rulesName(Rules rules);

// All incident faces quads: c = (n-3)/n, d = 2/n^2, e = 1/n^2 (n = valence), except
// Rules::Robust at n = 2: 0, 1/3, 1/6. n >= 2.
VertexWeights quadVertexWeights(Index n, Rules rules = Rules::Paper);

// At least one incident triangle: f = 1/(1 + n/2 + m/4), g = f/2, h = f/4 (m = quads).
VertexWeights mixedVertexWeights(Index n, Index m);

// True for vertices whose V-vertex keeps its position: boundary, non-manifold, unused.
inline bool isRetained(VertexKind kind) { return kind != VertexKind::Interior; }

// The paired method's positions: old vertices unchanged, then each face's centroid.
std::vector<double> pairedPositions(const Faces& faces, std::span<const double> positions);

// One P-S step's positions: V-vertices by the rules above, then F-vertices (face averages).
// The mesh must be P-S input (quads, triangles only on the boundary). With `splitBoundary`
// (Boundary::Smooth's split steps): a boundary vertex P between boundary neighbours a, b moves
// to (a + 6P + b) / 8, and each boundary edge's new point (a + b) / 2 follows, in edge order.
std::vector<double> psPositions(const Faces& faces, const Connectivity& connectivity,
                                std::span<const double> positions, Rules rules = Rules::Paper,
                                bool splitBoundary = false);

// Positions of hierarchy.levels[k] from those of levels[k-1] (paired method or P-S step).
std::vector<double> refineLevelPositions(const Hierarchy& hierarchy, std::size_t k,
                                         std::span<const double> parentPositions,
                                         Rules rules = Rules::Paper);

// Positions of the finest level of `hierarchy` from the control positions of levels[0].
std::vector<double> refinePositions(const Hierarchy& hierarchy, std::span<const double> control,
                                    Rules rules = Rules::Paper);

}  // namespace psub
