// The topological step shared by the paired method and P-S, the level hierarchy, and counts.
#include "psub/topology.h"

#include <chrono>

namespace psub {

Index firstNonPSFace(const Faces& faces, const Connectivity& c) {
    for (Index f = 0; f < faces.faceCount(); ++f) {
        const Index size = faces.faceSize(f);
        if (size == 4) continue;
        if (size == 3) {
            bool onBoundary = false;
            for (Index h = faces.offsets[f]; h < faces.offsets[f + 1]; ++h)
                onBoundary = onBoundary || c.twin[h] == kNoIndex;
            if (onBoundary) continue;
        }
        return f;
    }
    return kNoIndex;
}

bool needsPreprocessing(const Faces& faces, const Connectivity& c, Preprocess mode,
                        const Source& source) {
    if (mode == Preprocess::Always) return true;
    const Index bad = firstNonPSFace(faces, c);
    if (mode == Preprocess::Auto || bad == kNoIndex) return bad != kNoIndex;
    const Index size = faces.faceSize(bad);
    throw InputError(describeFace(source, bad) + " is " +
                     (size == 3 ? std::string("a triangle with no boundary edge")
                                : "a " + std::to_string(size) + "-gon") +
                     "; P-S input must be quads (plus triangles on the boundary): "
                     "use --preprocess auto or always");
}

Faces refineFaces(const Faces& faces, const Connectivity& c) {
    const Index oldVertices = faces.vertexCount;
    Faces child;
    child.vertexCount = oldVertices + faces.faceCount();
    child.offsets.reserve(std::size_t(c.edgeCount()) + 1);
    child.verts.reserve(std::size_t(c.edgeCount()) * 4);
    for (Index h : c.edgeHalfedge) {
        const Index a = faces.verts[h], b = faces.verts[c.next[h]];
        const Index ff = oldVertices + c.faceOf[h];
        if (c.twin[h] == kNoIndex) {
            const Index triangle[3] = {a, b, ff};
            child.addFace(triangle);
        } else {
            const Index quad[4] = {a, oldVertices + c.faceOf[c.twin[h]], b, ff};
            child.addFace(quad);
        }
    }
    return child;
}

Hierarchy refineTopology(Faces input, Connectivity connectivity, bool preprocess, int steps,
                         const std::function<void(int, double)>& onLevel) {
    Hierarchy hierarchy;
    hierarchy.preprocessed = preprocess;
    hierarchy.levels.push_back({std::move(input), std::move(connectivity)});
    const int total = steps + (preprocess ? 1 : 0);
    for (int level = 1; level <= total; ++level) {
        const auto start = std::chrono::steady_clock::now();
        const Level& parent = hierarchy.levels.back();
        Faces child = refineFaces(parent.faces, parent.connectivity);
        Connectivity childConnectivity = buildConnectivity(child);
        hierarchy.levels.push_back({std::move(child), std::move(childConnectivity)});
        const std::chrono::duration<double> seconds = std::chrono::steady_clock::now() - start;
        if (onLevel) onLevel(level, seconds.count());
    }
    return hierarchy;
}

Counts countMesh(const Faces& faces, const Connectivity& c) {
    Counts counts;
    counts.vertices = faces.vertexCount;
    counts.edges = c.edgeCount();
    counts.faces = faces.faceCount();
    counts.boundaryEdges = c.boundaryEdgeCount;
    for (Index f = 0; f < faces.faceCount(); ++f) {
        counts.triangles += faces.faceSize(f) == 3;
        counts.quads += faces.faceSize(f) == 4;
    }
    return counts;
}

Counts countsAfterSteps(const Counts& c, int steps) {
    if (steps <= 0) return c;
    const std::uint64_t half = std::uint64_t(1) << (steps - 1);  // 2^(k-1); caller keeps k < 40
    Counts k;
    k.edges = 2 * half * c.edges;
    k.faces = half * c.edges;
    k.vertices = c.vertices + c.faces + (half - 1) * c.edges;
    k.boundaryEdges = c.boundaryEdges;
    k.triangles = c.boundaryEdges;
    k.quads = k.faces - c.boundaryEdges;
    return k;
}

}  // namespace psub
