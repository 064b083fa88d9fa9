// The geometric rules of docs/scheme.md applied directly, vertex by vertex (the oracle).
#include "psub/rules.h"

#include <cassert>

namespace psub {

namespace {

// Rules::Shape's c, d, e per valence, from
//   psub analyze --optimize-shape --valence 3..16
// (centre weights searched per valence under the C1 conditions, closest to Catmull-Clark on
// the trapezohedron of that valence; docs/shape-rules.md tabulates what each gives).
struct ShapeEntry {
    Index valence;
    VertexWeights weights;
};
constexpr ShapeEntry kShapeWeights[] = {
    {3, {0.73999999999999999, 0, 0.08666666666666667}},
    {5, {0.75600000000000001, 0.045871999999999996, 0.002928}},
    {6, {0.79600000000000004, 0.033999999999999996, 0}},
    {7, {0.82399999999999995, 0.025142857142857151, 0}},
    {8, {0.84399999999999997, 0.019500000000000003, 0}},
    {9, {0.81200000000000006, 0.014622222222222215, 0.006266666666666666}},
    {10, {0.88800000000000001, 0.010751999999999999, 0.00044799999999999994}},
    {11, {0.90800000000000003, 0.007694545454545453, 0.00066909090909090889}},
    {12, {0.91600000000000004, 0.0062999999999999974, 0.00069999999999999967}},
    {13, {0.93999999999999995, 0.0030461538461538486, 0.0015692307692307707}},
    {14, {0.94000000000000006, 0.00059999999999999951, 0.0036857142857142822}},
    {15, {0.95999999999999996, 0.000693333333333334, 0.0019733333333333352}},
    {16, {0.95599999999999996, 0.0017600000000000014, 0.00099000000000000108}},
};

}  // namespace

const char* rulesName(Rules rules) {
    switch (rules) {
    case Rules::Robust: return "robust";
    case Rules::Shape: return "shape";
    case Rules::Paper: break;
    }
    return "paper";
}

VertexWeights quadVertexWeights(Index n, Rules rules) {
    if (rules != Rules::Paper && n == 2) return {0.0, 1.0 / 3, 1.0 / 6};
    if (rules == Rules::Shape)
        for (const ShapeEntry& entry : kShapeWeights)
            if (entry.valence == n) return entry.weights;
    const double nd = n;
    return {(nd - 3) / nd, 2 / (nd * nd), 1 / (nd * nd)};
}

const CornerRule& shapeCornerRule() {
    // `psub analyze --shape-tradeoff`'s point at a least gap of 0.138, the largest at which the
    // cube keeps half of Catmull-Clark's volume: alpha = 0.525, beta = 0, (c, d, e) =
    // (0.78, 0, 0.22 / 3); lambda1 0.371106, gap 0.1389 (docs/shape-rules.md, section 4).
    static const CornerRule rule{3, {0.78, 0.0, 0.22 / 3}, 0.525, 0.0};
    return rule;
}

bool cornerShaped(const Faces& faces, const Connectivity& c, Index v) {
    if (c.kind[v] != VertexKind::Interior || c.valence[v] != shapeCornerRule().valence) return false;
    for (Index h : c.outgoingOf(v))
        if (faces.faceSize(c.faceOf[h]) != 4) return false;
    return true;
}

std::vector<char> inputCorners(const Faces& input, const Connectivity& c, Rules rules) {
    std::vector<char> out;
    if (rules != Rules::Shape) return out;  // none: nothing allocated
    out.resize(input.vertexCount);
    for (Index v = 0; v < input.vertexCount; ++v) out[v] = cornerShaped(input, c, v);
    return out;
}

VertexWeights mixedVertexWeights(Index n, Index m) {
    const double f = 1 / (1 + n / 2.0 + m / 4.0);
    return {f, f / 2, f / 4};
}

namespace {

// Appends the average of each face's corners; a quad with corners marked in `corner` (input
// corners under Rules::Shape) weighs them by alpha and the others by (1 - alpha) / 3, divided
// by the sum of the four.
void appendFaceAverages(const Faces& faces, std::span<const double> positions,
                        std::span<const char> corner, std::vector<double>& out) {
    const double alpha = shapeCornerRule().faceCorner;
    for (Index f = 0; f < faces.faceCount(); ++f) {
        double sum[3] = {0, 0, 0}, total = 0;
        bool weighted = false;
        if (!corner.empty() && faces.faceSize(f) == 4)
            for (Index v : faces.face(f)) weighted = weighted || corner[v];
        for (Index v : faces.face(f)) {
            const double w = !weighted ? 1.0 : corner[v] ? alpha : (1 - alpha) / 3;
            total += w;
            for (int axis = 0; axis < 3; ++axis) sum[axis] += w * positions[3 * v + axis];
        }
        for (int axis = 0; axis < 3; ++axis) out.push_back(sum[axis] / total);
    }
}

}  // namespace

std::vector<double> pairedPositions(const Faces& faces, std::span<const double> positions) {
    std::vector<double> out(positions.begin(), positions.end());
    appendFaceAverages(faces, positions, {}, out);
    return out;
}

std::vector<double> psPositions(const Faces& faces, const Connectivity& c,
                                std::span<const double> positions, Rules rules, bool splitBoundary,
                                const std::vector<char>* inputCorners) {
    std::vector<char> corner;
    if (rules == Rules::Shape) {
        const std::vector<char> own = inputCorners ? std::vector<char>{} : psub::inputCorners(faces, c, rules);
        const std::vector<char>& input = inputCorners ? *inputCorners : own;
        corner.resize(faces.vertexCount);
        for (Index v = 0; v < faces.vertexCount; ++v) corner[v] = v < input.size() && input[v] && cornerShaped(faces, c, v);
    }
    const CornerRule& cornerRule = shapeCornerRule();
    std::vector<double> out;
    out.reserve(3 * (std::size_t(faces.vertexCount) + faces.faceCount() + c.boundaryEdgeCount));
    for (Index v = 0; v < faces.vertexCount; ++v) {
        const double* p = &positions[3 * v];
        if (splitBoundary && c.kind[v] == VertexKind::Boundary) {
            const BoundaryNeighbours around = boundaryNeighbours(faces, c, v);
            for (int axis = 0; axis < 3; ++axis)
                out.push_back((positions[3 * around.previous + axis] + 6 * p[axis] +
                               positions[3 * around.next + axis]) / 8);
            continue;
        }
        if (isRetained(c.kind[v])) {
            out.insert(out.end(), p, p + 3);
            continue;
        }
        // Interior: each outgoing half-edge v->q gives the edge neighbour q and, in a quad,
        // the diagonal opposite v. Edge neighbours that are input corners are summed apart.
        double edgeSum[3] = {0, 0, 0}, cornerSum[3] = {0, 0, 0}, diagonalSum[3] = {0, 0, 0};
        Index quads = 0, triangles = 0, cornerNeighbours = 0;
        for (Index h : c.outgoingOf(v)) {
            const Index q = faces.verts[c.next[h]];
            const bool atCorner = !corner.empty() && corner[q];
            cornerNeighbours += atCorner ? 1 : 0;
            for (int axis = 0; axis < 3; ++axis) (atCorner ? cornerSum : edgeSum)[axis] += positions[3 * q + axis];
            const Index size = faces.faceSize(c.faceOf[h]);
            assert(size == 3 || size == 4);
            if (size == 3) {
                ++triangles;
                continue;
            }
            ++quads;
            const Index d = faces.verts[c.next[c.next[h]]];
            for (int axis = 0; axis < 3; ++axis) diagonalSum[axis] += positions[3 * d + axis];
        }
        const Index n = c.valence[v];
        VertexWeights w = triangles == 0 ? quadVertexWeights(n, rules) : mixedVertexWeights(n, quads);
        if (!corner.empty() && corner[v]) w = cornerRule.centre;
        // Beside an input corner, a regular vertex weighs the corner by beta, not 1/8, and
        // keeps the difference (a corner's neighbours are never corners: valence 3 != 4).
        double cornerWeight = w.edge;
        if (cornerNeighbours > 0 && triangles == 0 && n == 4) {
            cornerWeight = cornerRule.neighbour;
            w.centre += cornerNeighbours * (w.edge - cornerRule.neighbour);
        }
        for (int axis = 0; axis < 3; ++axis)
            out.push_back(w.centre * p[axis] + w.edge * edgeSum[axis] + cornerWeight * cornerSum[axis] +
                          w.diagonal * diagonalSum[axis]);
    }
    appendFaceAverages(faces, positions, corner, out);
    if (!splitBoundary) return out;
    for (Index h : c.edgeHalfedge) {
        if (c.twin[h] != kNoIndex) continue;
        const Index a = faces.verts[h], b = faces.verts[c.next[h]];
        for (int axis = 0; axis < 3; ++axis)
            out.push_back((positions[3 * a + axis] + positions[3 * b + axis]) / 2);
    }
    return out;
}

std::vector<double> refineLevelPositions(const Hierarchy& hierarchy, std::size_t k,
                                         std::span<const double> parentPositions, Rules rules) {
    const Level& parent = hierarchy.levels[k - 1];
    const Level& input = hierarchy.levels.front();
    const std::vector<char> corners = inputCorners(input.faces, input.connectivity, rules);
    const bool paired = hierarchy.preprocessed && k == 1;
    return paired ? pairedPositions(parent.faces, parentPositions)
                  : psPositions(parent.faces, parent.connectivity, parentPositions, rules,
                                hierarchy.splitsBoundary(k), &corners);
}

std::vector<double> refinePositions(const Hierarchy& hierarchy, std::span<const double> control,
                                    Rules rules) {
    std::vector<double> positions(control.begin(), control.end());
    for (std::size_t k = 1; k < hierarchy.levels.size(); ++k)
        positions = refineLevelPositions(hierarchy, k, positions, rules);
    return positions;
}

}  // namespace psub
