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
// Shape (beyond the paper, never the default): Robust, and at an interior vertex of valence 3
// or 5..16 with all faces quads, c, d, e from a table chosen by `psub analyze --optimize-shape`
// (docs/shape-rules.md): the surface keeps more of Catmull-Clark's shape at low valence while
// the necessary C1 conditions hold with a spectral gap of at least 0.12 (or the paper's own,
// if smaller). An input corner (below) follows shapeCornerRule() instead, which also changes
// the rows of its neighbours. Valence 4 (regular, unless beside an input corner), valence
// above 16, mixed vertices and the boundary follow the paper.
enum class Rules { Paper, Robust, Shape };

// "paper", "robust" or "shape".
const char* rulesName(Rules rules);

// All incident faces quads: c = (n-3)/n, d = 2/n^2, e = 1/n^2 (n = valence), except
// Rules::Robust and Rules::Shape at n = 2: 0, 1/3, 1/6, and Rules::Shape's table at n = 3
// and 5..16. n >= 2.
VertexWeights quadVertexWeights(Index n, Rules rules = Rules::Paper);

// Rules::Shape at an input corner: a vertex of the input mesh that is interior, of valence 3
// and has only quads around it, in the input and so at every level after (old vertex v keeps
// number v, its valence and its kind through every step, the paired method's included). A
// triangle mesh's vertices of valence 3 and the paired method's centroids are no corners and
// keep the vertex weights (docs/shape-rules.md measures why). Three weights change
// (docs/shape-rules.md, section 4), chosen by `psub analyze --shape-tradeoff` as the point with
// the largest least spectral gap (0.138) at which the cube keeps half of Catmull-Clark's volume:
// - the corner's own c, d, e (`centre`);
// - a quad's F-vertex weighs each corner of that kind by `faceCorner` (alpha) and each other
//   corner by (1 - alpha) / 3, divided by their sum (one such corner: alpha and (1 - alpha) / 3);
// - a regular vertex (valence 4, all quads, not itself a corner) weighs each edge neighbour of
//   that kind by `neighbour` (beta) instead of 1/8, the difference going to its own weight.
// Tables carry beta = 0 only (the neighbour leaves the row; docs/shape-rules.md).
struct CornerRule {
    Index valence;
    VertexWeights centre;
    double faceCorner, neighbour;
};
const CornerRule& shapeCornerRule();

// Interior, valence 3, only quads around: the shape of a corner (see CornerRule).
bool cornerShaped(const Faces& faces, const Connectivity& connectivity, Index v);

// Per vertex of an input mesh: 1 for an input corner under `rules`; empty for the rule sets
// without corners (all but Rules::Shape).
std::vector<char> inputCorners(const Faces& input, const Connectivity& connectivity, Rules rules);

// At least one incident triangle: f = 1/(1 + n/2 + m/4), g = f/2, h = f/4 (m = quads).
VertexWeights mixedVertexWeights(Index n, Index m);

// True for vertices whose V-vertex keeps its position: boundary, non-manifold, unused.
inline bool isRetained(VertexKind kind) { return kind != VertexKind::Interior; }

// The paired method's positions: old vertices unchanged, then each face's centroid.
std::vector<double> pairedPositions(const Faces& faces, std::span<const double> positions);

// One P-S step's positions: V-vertices by the rules above, then F-vertices (face averages;
// Rules::Shape: weighted beside an input corner). The mesh must be P-S input (quads, triangles
// only on the boundary). `inputCorners`: inputCorners() of the hierarchy's input (vertices
// numbered past it are none); null: this mesh is the input. With `splitBoundary`
// (Boundary::Smooth's split steps): a boundary vertex P between boundary neighbours a, b moves
// to (a + 6P + b) / 8, and each boundary edge's new point (a + b) / 2 follows, in edge order.
std::vector<double> psPositions(const Faces& faces, const Connectivity& connectivity,
                                std::span<const double> positions, Rules rules = Rules::Paper,
                                bool splitBoundary = false, const std::vector<char>* inputCorners = nullptr);

// Positions of hierarchy.levels[k] from those of levels[k-1] (paired method or P-S step).
std::vector<double> refineLevelPositions(const Hierarchy& hierarchy, std::size_t k,
                                         std::span<const double> parentPositions,
                                         Rules rules = Rules::Paper);

// Positions of the finest level of `hierarchy` from the control positions of levels[0].
std::vector<double> refinePositions(const Hierarchy& hierarchy, std::span<const double> control,
                                    Rules rules = Rules::Paper);

}  // namespace psub
