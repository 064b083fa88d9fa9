// psub/analysis.h: the engine checks the paper's claims for itself, from its own stencil
// tables. Around an interior vertex of valence n surrounded by quads: the local TWO-step
// subdivision matrix (P-S turns the grid by 45 degrees each step, so one step is not
// self-similar), its leading eigenvalues and the necessary C1 conditions, the characteristic
// map, and a numerical tangent-plane check; Catmull-Clark's matrix from OpenSubdiv's stencils
// beside it. On whole meshes: P-S after 2k steps against Catmull-Clark after k steps (volume,
// area, bounding box, two-sided Hausdorff distance) and a small PNG plot of it.
// Never used per frame; clarity over speed.
#pragma once

#include "psub/rules.h"
#include "psub/topology.h"

#include <algorithm>
#include <array>
#include <complex>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace psub {

// ---------------------------------------------------------------------------------------
// Local meshes around an extraordinary vertex

// Where a vertex sits in the quad grid around a centre of valence n. Sector s (0..n-1) lies
// between spokes s and s+1; (i, j) counts grid steps along spoke s and spoke s+1. Canonical
// form: the centre is {0, 0, 0}; every other grid point has j >= 1 (the point (s, i, 0) on
// spoke s is written (s-1, 0, i)). sector < 0: not a grid point (boundary triangles' points).
struct GridKey {
    int sector = -1, i = 0, j = 0;

    bool valid() const { return sector >= 0; }
    int ring() const { return std::max(i, j); }  // 0 for the centre
    bool operator==(const GridKey&) const = default;
};

// The vertex of valence `valence` (index 0) with `rings` rings of quads around it
// (valence * rings^2 quads, a disk). Planar layout: sector s is the unit grid of a quadrant,
// opened to an angle of 2 pi / valence (z -> |z| e^(i arg(z) 4 / valence), turned by
// 2 pi s / valence), plus `bump` times a smooth height field in z. valence >= 2, rings >= 1.
struct LocalMesh {
    Index valence = 0;
    int rings = 0;
    Mesh mesh;
    std::vector<GridKey> keys;  // per vertex, canonical
};
LocalMesh makeLocalMesh(Index valence, int rings, double bump = 0);

// A local subdivision matrix on an invariant neighbourhood of the centre: the vertices of
// rings 0..rings, 1 + valence * rings * (rings + 1) of them, ordered by ring, then sector,
// i, j. Row r holds the refined vertex with grid key keys[r] (on the refined grid, whose unit
// is half the coarse one) as weights of the coarse vertices keys[0..size()).
struct LocalMatrix {
    Index valence = 0;
    int rings = 0;
    std::vector<GridKey> keys;
    std::vector<double> weights;  // dense, row-major, size() x size()

    std::size_t size() const { return keys.size(); }
    double at(std::size_t row, std::size_t column) const { return weights[row * size() + column]; }
};

// The two-step P-S matrix from the engine's own per-level tables (buildPerLevelTable with
// `rules` on makeLocalMesh(valence, rings + 2), two steps composed in double); refined and
// coarse vertices are matched by grid key. rings >= 3 (the smallest invariant neighbourhood).
// Throws std::logic_error when a row reaches outside the neighbourhood or does not sum to 1.
LocalMatrix psTwoStepMatrix(Index valence, Rules rules, int rings = 3);

// The same with the centre's weights (c, d, e) replaced by `centre` in the table (the shape
// optimiser's candidates). valence != 4: every other interior vertex there is regular.
LocalMatrix psTwoStepMatrix(Index valence, VertexWeights centre, int rings = 3);

// Catmull-Clark's one-step matrix from OpenSubdiv's stencils
// (Far::StencilTableFactoryReal<double> on a Far::TopologyRefiner of makeLocalMesh, one
// uniform level), matched by grid key the same way. rings >= 1. Same checks.
LocalMatrix catmarkOneStepMatrix(Index valence, int rings = 1);

// Catmull-Clark's subdominant eigenvalue in closed form:
// (5 + cos(2 pi / n) + cos(pi / n) sqrt(2 (9 + cos(2 pi / n)))) / 16.
double catmarkSubdominantClosedForm(Index valence);

// All eigenvalues (Eigen::EigenSolver), descending by modulus; ties: larger real part, then
// larger imaginary part first.
std::vector<std::complex<double>> eigenvalues(const LocalMatrix& matrix);

// ---------------------------------------------------------------------------------------
// Smoothness at one valence

// Beyond the vertex weights (see shapeTradeoff below; Rules::Shape's corner rule is one point).
// Rules next to an extraordinary interior vertex P of valence n with quads around it, which
// reach the modes k != 0 and so move lambda1 itself. A "corner of valence n" below is a vertex
// whose table row is a VertexQuad row of valence n.
struct ExtendedShapeRule {
    Index valence = 3;          // n, 3 or more, not 4
    VertexWeights centre{};     // P's own rule (c, d, e)
    // alpha: a quad's F-vertex weighs each corner of valence n by alpha and each other corner
    // by (1 - alpha) / 3, divided by their sum (one such corner: exactly alpha and
    // (1 - alpha) / 3; the paper: 1/4).
    double faceCorner = 0.25;
    // beta: a regular vertex's rule weighs each edge neighbour of valence n by beta instead of
    // 1/8; the difference goes to the vertex itself (the paper: 1/8).
    double neighbourCentre = 0.125;
};

// Rules::Shape's corner rule (psub/rules.h) as an extended rule: what its tables carry.
ExtendedShapeRule extendedRuleOf(const CornerRule& corner);

struct ValenceOptions {
    int characteristicRings = 8;  // rings of the characteristic map's control net, >= 4
    int tangentLevels = 10;       // two-step levels of the tangent-plane check, >= 1
    double tolerance = 1e-8;      // relative: "real", "equal" and "larger" for eigenvalues
    // Set: the centre's weights instead of those of the rule set (valence != 4).
    std::optional<VertexWeights> centreWeights;
    // Set: the experimental rule below instead (its valence must be `valence`).
    std::optional<ExtendedShapeRule> extendedRule;
};

struct ValenceReport {
    Index valence = 0;
    Rules rules = Rules::Paper;
    std::size_t matrixSize = 0;  // of the 3-ring two-step matrix: 1 + 12 valence
    std::vector<std::complex<double>> eigenvalues;  // the leading 6, descending by modulus
    // lambda0 = 1, lambda1 = lambda2 real and equal, 1 > lambda1 > |lambda3|: necessary for C1.
    bool c1Necessary = false;
    double lambda1 = 0;                    // real part of the subdominant eigenvalue
    double lambda3OverLambda1Squared = 0;  // |lambda3| / lambda1^2: curvature (1: bounded)
    double spectralGap = 0;                // lambda1 - |lambda3|: how safely C1's margin holds
    // Characteristic map: the two subdominant eigenvectors, extended to characteristicRings
    // rings, map the control net to the plane. Injective when every control ring winds once
    // around the origin (all the same way) and every face of the outer annulus
    // (rings characteristicRings/2 .. characteristicRings, which two-step refinement maps
    // onto the next annulus in) has area of that same sign.
    bool characteristicMapInjective = false;
    std::vector<int> ringWindings;          // rings 1..characteristicRings
    std::uint64_t annulusFaces = 0;         // faces checked in the outer annulus
    std::uint64_t foldedAnnulusFaces = 0;   // of them, with the wrong sign or no area
    std::uint64_t foldedFaces = 0;          // the same over all rings (information only)
    // Tangent plane: a bumpy 3-ring neighbourhood refined two steps at a time (cropped to the
    // invariant neighbourhood each time): the largest angle between the normals of two faces
    // within ring 2, per level 0..tangentLevels. Tends to 0 where the limit is C1.
    std::vector<double> normalSpreadDegrees;
    // Catmull-Clark at the same valence: lambda1 of OpenSubdiv's one-step matrix, and the
    // closed form it is checked against.
    double ccLambda1 = 0, ccLambda1ClosedForm = 0;
};

// Everything above for one valence (>= 2) and rule set.
ValenceReport analyzeValence(Index valence, Rules rules, const ValenceOptions& options = {});

// ---------------------------------------------------------------------------------------
// Fidelity: P-S against Catmull-Clark on a mesh

struct MeshMeasures {
    double volume = 0;  // signed, fan-triangulated faces (divergence theorem); closed meshes
    double area = 0;
    std::array<double, 3> lo{}, hi{};  // bounding box of the vertices used by faces
    double diagonal() const;
};

MeshMeasures measureMesh(const Faces& faces, std::span<const double> positions);

// Distances from points sampled on every face of `from` (faces fan-triangulated; each triangle
// sampled on a barycentric grid with `samplesPerEdge` intervals, corners included) to the
// nearest point of the triangles of `to`, found through a kd-tree of their bounding boxes (NaN
// for a non-finite sample point). samplesPerEdge >= 1. Both meshes must have at least one face;
// coordinates beyond about 1e75 (the point-triangle test would overflow) throw
// std::invalid_argument.
std::vector<double> surfaceDistances(const Faces& from, std::span<const double> fromPositions,
                                     const Faces& to, std::span<const double> toPositions,
                                     int samplesPerEdge);

struct Fidelity {
    int psSteps = 0, ccLevels = 0;
    Index psFaces = 0, ccFaces = 0;
    MeshMeasures input, ps, cc;
    std::vector<double> psToCc, ccToPs;  // sampled distances, each direction
    // Per interior vertex of the P-S result whose valence is not 4 (the input's extraordinary
    // vertices and the paired method's centroids; every later vertex has valence 4): the largest
    // angle in degrees between the normals of two faces around it. Near 0: smooth there.
    std::vector<double> evNormalSpreads;
    double hausdorff() const;            // max over both directions
    double meanDistance() const;         // over all samples of both directions
};

// P-S after `psSteps` (even) steps with `rules` and `boundary` (plus the paired method when the
// input needs it, through the engine's tables and CPU evaluator) against OpenSubdiv's
// Catmull-Clark after psSteps / 2 levels, on a checked mesh. samplesPerEdge 0: measures only, no distances.
Fidelity compareWithCatmark(const Mesh& mesh, const Connectivity& connectivity, int psSteps,
                            Rules rules = Rules::Paper, int samplesPerEdge = 2,
                            Boundary boundary = Boundary::Paper);

// ---------------------------------------------------------------------------------------
// Boundary triangles: the paper never refines the boundary, so the triangles along it grow
// thin; Boundary::Smooth (beyond the paper) splits boundary edges every second step.

struct BoundaryAspect {
    std::uint64_t triangles = 0;  // triangles with a boundary edge
    double worst = 0, median = 0;  // longest edge / height on it (equilateral: 1.155)
};

// Aspect ratios of the triangles of `faces` that have a boundary edge.
BoundaryAspect boundaryTriangleAspect(const Faces& faces, const Connectivity& connectivity,
                                      std::span<const double> positions);

// boundaryTriangleAspect after each of P-S steps 1..psSteps (after the paired method when the
// mesh needs it) of a checked mesh, positions from the rule oracle in double. Keeps every
// level: meant for small meshes.
std::vector<BoundaryAspect> boundaryAspectByLevel(const Mesh& mesh, const Connectivity& connectivity,
                                                  int psSteps, Boundary boundary, Rules rules = Rules::Paper);

// A PNG (libpng) of `fidelity`: bars of P-S / Catmull-Clark for volume, area and box
// diagonal, and the histograms of both distance directions relative to the box diagonal,
// titled `title`. Written by psub::writePng (atomic for a regular file); throws a std::runtime_error
// (psub::OutputError when writing fails) naming the path.
void writeFidelityPlot(const std::string& path, const Fidelity& fidelity, const std::string& title);

// ---------------------------------------------------------------------------------------
// The shape optimiser behind Rules::Shape (run once: `psub analyze --optimize-shape`; its
// output is the table in rules.cpp). Only the centre weights (c, d, e) of a valence change, so
// only the rotation-invariant part of the two-step matrix moves: lambda1 and the
// characteristic map stay, and C1 holds while the other eigenvalues stay below lambda1.

// A closed quad mesh with two poles of valence n on the z axis at +-sqrt(3) and 2n vertices
// of valence 3, alternating at z = +-1/sqrt(3) on the circle of radius sqrt(8/3): the n-gonal
// trapezohedron. n = 3 is the cube [-1, 1]^3, turned to stand on a corner. n >= 3.
Mesh trapezohedron(Index n);

struct ShapeSearchOptions {
    int psSteps = 4;                   // P-S steps against Catmull-Clark psSteps / 2 levels
    int samplesPerEdge = 2;            // of the Hausdorff distance
    double minimumGap = 0.12;          // lambda1 - |lambda3|, or the paper's own gap if smaller
    double maximumNormalSpread = 30;   // degrees, analyzeValence's after 10 two-step levels
};

// One candidate's centre weights at one valence and what they give.
struct ShapeCandidate {
    Index valence = 0;
    VertexWeights weights{};
    double lambda1 = 0, spectralGap = 0;  // of the 3-ring two-step matrix
    double volumeRatio = 0;               // P-S / Catmull-Clark on trapezohedron(valence)
    double hausdorff = 0;                 // two-sided, relative to Catmull-Clark's box diagonal
    double normalSpreadDegrees = 0;       // set by the full check only
    bool c1 = false;                      // full check: C1 conditions, injective map, spread bound
    double objective() const { return std::abs(volumeRatio - 1) + hausdorff; }
};

// Searches (c, d, e) >= 0 with c + n d + n e = 1 at valence n (3 or more, not 4) on a grid of
// c and of the share of 1 - c given to the diagonals, then on a finer grid around the best;
// keeps candidates whose spectral gap meets options.minimumGap (or the paper's gap at n when
// that is smaller), ranks them by objective() on trapezohedron(n) (its valence-3 vertices
// follow `valence3`; at n = 3 the candidate itself), and returns the best that passes
// analyzeValence's C1 checks and the normal spread bound. Throws std::runtime_error if none.
ShapeCandidate optimizeShapeWeights(Index valence, VertexWeights valence3, const ShapeSearchOptions& options = {});

// The paper's spectral gap at valence n (lambda1 - |lambda3| of the 3-ring two-step matrix).
double paperSpectralGap(Index valence);

// ---------------------------------------------------------------------------------------
// Beyond the vertex weights: any such rule, applied while composing the paper's table (the
// engine's tables carry one point, Rules::Shape's corner rule, with their own row kinds).
// ExtendedShapeRule (above, before ValenceOptions) says what these rules are.

// The two-step matrix with `rule` applied to the paper's per-level table while composing it
// in double (the rows' supports do not change, so the same neighbourhood is invariant).
LocalMatrix psTwoStepMatrix(const ExtendedShapeRule& rule, int rings = 3);

// `psSteps` P-S steps of a closed all-quad mesh with `rule` applied, in double: the finest
// level's faces and positions.
struct ExtendedRefinement {
    Faces faces;
    std::vector<double> positions;
};
ExtendedRefinement refineExtended(const Mesh& mesh, int psSteps, const ExtendedShapeRule& rule);

struct ExtendedCandidate {
    ExtendedShapeRule rule;
    double lambda1 = 0, spectralGap = 0;   // of the 3-ring two-step matrix
    double volumeRatio = 0;           // the cube, P-S psSteps against CC psSteps / 2
    double hausdorff = 0;             // the same, relative to CC's box diagonal (measured ones only)
    double normalSpreadDegrees = 0;   // analyzeValence's bumpy neighbourhood, 10 two-step levels
    double cornerSpreadDegrees = 0;   // at the cube's corners after cornerSteps P-S steps
    bool c1 = false;                  // analyzeValence: C1 conditions and injective map
};

struct TradeoffOptions {
    int psSteps = 4, cornerSteps = 10, samplesPerEdge = 2;
    std::vector<double> faceCorners, neighbourCentres;  // alpha and beta values to search
    int centreSteps = 50;   // c in steps of 1 / centreSteps in [0, 1)
    int shareSteps = 4;     // the diagonals' share of 1 - c in steps of 1 / shareSteps
};

// Everything above for one rule of valence 3: analyzeValence's checks and the cube.
ExtendedCandidate measureExtendedRule(const ExtendedShapeRule& rule, const TradeoffOptions& options = {});

// At valence 3, on the cube: for each least gap, the candidate (c, d, e, alpha, beta) on the
// grid of `options` with the smallest |volume ratio - 1| among those whose spectral gap is at
// least that and that pass analyzeValence's C1 checks. Throws std::runtime_error if none.
std::vector<ExtendedCandidate> shapeTradeoff(std::span<const double> leastGaps, const TradeoffOptions& options);

}  // namespace psub
