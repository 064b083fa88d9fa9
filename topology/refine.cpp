// The topological step shared by the paired method and P-S, the level hierarchy, and counts.
#include "connectivity_detail.h"
#include "psub/topology.h"

#include <algorithm>
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

// Every child half-edge but the kept boundary edges is a "spoke" between an old vertex v and
// the point of a face f holding v at corner c: one half-edge v->F(f) and one F(f)->v, twins.
// Recording both per corner c pairs all twins without searching.
Level refineLevel(const Level& parent) {
    const Faces& pf = parent.faces;
    const Connectivity& pc = parent.connectivity;
    const Index oldVertices = pf.vertexCount, edges = pc.edgeCount();
    const Index childHalfedges = 4 * (edges - pc.boundaryEdgeCount) + 3 * pc.boundaryEdgeCount;

    Level child;
    Faces& cf = child.faces;
    Connectivity& cc = child.connectivity;
    cf.vertexCount = oldVertices + pf.faceCount();
    cf.offsets.resize(std::size_t(edges) + 1);
    cf.verts.resize(childHalfedges);
    cc.faceOf.resize(childHalfedges);
    cc.next.resize(childHalfedges);
    cc.twin.resize(childHalfedges);
    std::vector<Index> toFace(pf.verts.size()), fromFace(pf.verts.size());  // per corner c

    Index k = 0;
    for (Index e = 0; e < edges; ++e) {
        const Index h = pc.edgeHalfedge[e], t = pc.twin[h], nh = pc.next[h];
        const Index a = pf.verts[h], b = pf.verts[nh], ff = oldVertices + pc.faceOf[h];
        cf.offsets[e] = k;
        if (t == kNoIndex) {  // [a, b, F(f)]
            const Index corners[3] = {a, b, ff};
            std::copy(corners, corners + 3, &cf.verts[k]);
            cc.twin[k] = kNoIndex;
            toFace[nh] = k + 1;
            fromFace[h] = k + 2;
        } else {  // [a, F(g), b, F(f)]
            const Index corners[4] = {a, oldVertices + pc.faceOf[t], b, ff};
            std::copy(corners, corners + 4, &cf.verts[k]);
            toFace[pc.next[t]] = k;
            fromFace[t] = k + 1;
            toFace[nh] = k + 2;
            fromFace[h] = k + 3;
        }
        const Index size = t == kNoIndex ? 3 : 4;
        for (Index i = 0; i < size; ++i) {
            cc.faceOf[k + i] = e;
            cc.next[k + i] = k + (i + 1) % size;
        }
        k += size;
    }
    cf.offsets[edges] = k;
    for (Index c = 0; c < pf.verts.size(); ++c) {
        cc.twin[toFace[c]] = fromFace[c];
        cc.twin[fromFace[c]] = toFace[c];
    }
    completeConnectivity(cf, cc);
    // Old vertices keep their kind; a face point is always interior (its fan is the face).
    cc.kind.assign(pc.kind.begin(), pc.kind.end());
    cc.kind.resize(cf.vertexCount, VertexKind::Interior);
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
        hierarchy.levels.push_back(refineLevel(hierarchy.levels.back()));
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
