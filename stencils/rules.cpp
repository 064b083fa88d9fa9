// The geometric rules of docs/scheme.md applied directly, vertex by vertex (the oracle).
#include "psub/rules.h"

#include <cassert>

namespace psub {

const char* rulesName(Rules rules) { return rules == Rules::Robust ? "robust" : "paper"; }

VertexWeights quadVertexWeights(Index n, Rules rules) {
    if (rules == Rules::Robust && n == 2) return {0.0, 1.0 / 3, 1.0 / 6};
    const double nd = n;
    return {(nd - 3) / nd, 2 / (nd * nd), 1 / (nd * nd)};
}

VertexWeights mixedVertexWeights(Index n, Index m) {
    const double f = 1 / (1 + n / 2.0 + m / 4.0);
    return {f, f / 2, f / 4};
}

namespace {

// Appends the average of each face's corners.
void appendFaceAverages(const Faces& faces, std::span<const double> positions,
                        std::vector<double>& out) {
    for (Index f = 0; f < faces.faceCount(); ++f) {
        double sum[3] = {0, 0, 0};
        for (Index v : faces.face(f))
            for (int axis = 0; axis < 3; ++axis) sum[axis] += positions[3 * v + axis];
        for (int axis = 0; axis < 3; ++axis) out.push_back(sum[axis] / faces.faceSize(f));
    }
}

}  // namespace

std::vector<double> pairedPositions(const Faces& faces, std::span<const double> positions) {
    std::vector<double> out(positions.begin(), positions.end());
    appendFaceAverages(faces, positions, out);
    return out;
}

std::vector<double> psPositions(const Faces& faces, const Connectivity& c,
                                std::span<const double> positions, Rules rules, bool splitBoundary) {
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
        // the diagonal opposite v.
        double edgeSum[3] = {0, 0, 0}, diagonalSum[3] = {0, 0, 0};
        Index quads = 0, triangles = 0;
        for (Index h : c.outgoingOf(v)) {
            const Index q = faces.verts[c.next[h]];
            for (int axis = 0; axis < 3; ++axis) edgeSum[axis] += positions[3 * q + axis];
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
        const VertexWeights w = triangles == 0 ? quadVertexWeights(n, rules) : mixedVertexWeights(n, quads);
        for (int axis = 0; axis < 3; ++axis)
            out.push_back(w.centre * p[axis] + w.edge * edgeSum[axis] +
                          w.diagonal * diagonalSum[axis]);
    }
    appendFaceAverages(faces, positions, out);
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
    const bool paired = hierarchy.preprocessed && k == 1;
    return paired ? pairedPositions(parent.faces, parentPositions)
                  : psPositions(parent.faces, parent.connectivity, parentPositions, rules,
                                hierarchy.splitsBoundary(k));
}

std::vector<double> refinePositions(const Hierarchy& hierarchy, std::span<const double> control,
                                    Rules rules) {
    std::vector<double> positions(control.begin(), control.end());
    for (std::size_t k = 1; k < hierarchy.levels.size(); ++k)
        positions = refineLevelPositions(hierarchy, k, positions, rules);
    return positions;
}

}  // namespace psub
