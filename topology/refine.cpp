// The topological step shared by the paired method and P-S, the level hierarchy, and counts.
#include "connectivity_detail.h"
#include "psub/topology.h"

#include <algorithm>
#include <chrono>
#include <initializer_list>

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

const char* boundaryName(Boundary boundary) {
    return boundary == Boundary::Smooth ? "smooth" : "paper";
}

BoundaryNeighbours boundaryNeighbours(const Faces& faces, const Connectivity& c, Index v) {
    BoundaryNeighbours found{kNoIndex, kNoIndex};
    for (Index h : c.outgoingOf(v)) {
        if (c.twin[h] == kNoIndex) found.next = faces.verts[c.next[h]];
        Index into = h;  // the half-edge of the same face that ends at v
        while (c.next[into] != h) into = c.next[into];
        if (c.twin[into] == kNoIndex) found.previous = faces.verts[into];
    }
    return found;
}

Faces refineFaces(const Faces& faces, const Connectivity& c, bool splitBoundary) {
    const Index oldVertices = faces.vertexCount, boundary = c.boundaryEdgeCount;
    Faces child;
    child.vertexCount = oldVertices + faces.faceCount() + (splitBoundary ? boundary : 0);
    child.offsets.reserve(std::size_t(c.edgeCount()) + (splitBoundary ? boundary : 0) + 1);
    child.verts.reserve(4 * std::size_t(c.edgeCount() - boundary) + (splitBoundary ? 6 : 3) * std::size_t(boundary));
    // Corners appended one by one (Faces::addFace's range insert costs a call per face).
    const auto add = [&child](std::initializer_list<Index> corners) {
        for (Index v : corners) child.verts.push_back(v);
        child.offsets.push_back(Index(child.verts.size()));
    };
    Index edgePoint = oldVertices + faces.faceCount();
    for (Index h : c.edgeHalfedge) {
        const Index a = faces.verts[h], b = faces.verts[c.next[h]];
        const Index ff = oldVertices + c.faceOf[h];
        if (c.twin[h] == kNoIndex && splitBoundary) {
            add({a, edgePoint, ff});
            add({edgePoint, b, ff});
            ++edgePoint;
        } else if (c.twin[h] == kNoIndex) {
            add({a, b, ff});
        } else {
            add({a, oldVertices + c.faceOf[c.twin[h]], b, ff});
        }
    }
    return child;
}

namespace {

// Appends face `corners` to a level under construction: corners, faceOf and next.
void appendChildFace(Faces& cf, Connectivity& cc, Index& k, std::initializer_list<Index> corners) {
    const Index face = Index(cf.offsets.size()) - 1, size = Index(corners.size());
    std::copy(corners.begin(), corners.end(), &cf.verts[k]);
    for (Index i = 0; i < size; ++i) {
        cc.faceOf[k + i] = face;
        cc.next[k + i] = k + (i + 1) % size;
    }
    k += size;
    cf.offsets.push_back(k);
}

}  // namespace

// Every child half-edge but the boundary edges is a "spoke" between an old vertex v and the
// point of a face f holding v at corner c: one half-edge v->F(f) and one F(f)->v, twins.
// Recording both per corner c pairs all twins without searching. A split boundary edge adds
// one more pair: M->F(f) and F(f)->M, twins of each other.
namespace {

// refineLevel; with `consumed` (the parent itself), the parent's topology is freed as soon as
// the child's faces and twins exist, and what the step never reads before that.
Level refineLevelFrom(const Level& parent, bool splitBoundary, Level* consumed) {
    if (consumed) {  // the step reads faces, faceOf, next, twin, edgeHalfedge and kind
        Connectivity& unread = consumed->connectivity;
        unread.outgoing = {};
        unread.outOffsets = {};
        unread.edgeOf = {};
        unread.valence = {};
    }
    const Faces& pf = parent.faces;
    const Connectivity& pc = parent.connectivity;
    const Index oldVertices = pf.vertexCount, edges = pc.edgeCount();
    const Index boundary = pc.boundaryEdgeCount;
    const Index childHalfedges = 4 * (edges - boundary) + (splitBoundary ? 6 : 3) * boundary;

    Level child;
    Faces& cf = child.faces;
    Connectivity& cc = child.connectivity;
    cf.vertexCount = oldVertices + pf.faceCount() + (splitBoundary ? boundary : 0);
    cf.offsets.reserve(std::size_t(edges) + (splitBoundary ? boundary : 0) + 1);
    cf.offsets.assign(1, 0);
    cf.verts.resize(childHalfedges);
    cc.faceOf.resize(childHalfedges);
    cc.next.resize(childHalfedges);
    cc.twin.assign(childHalfedges, kNoIndex);
    std::vector<Index> toFace(pf.verts.size()), fromFace(pf.verts.size());  // per corner c

    Index k = 0, edgePoint = oldVertices + pf.faceCount();
    for (Index e = 0; e < edges; ++e) {
        const Index h = pc.edgeHalfedge[e], t = pc.twin[h], nh = pc.next[h];
        const Index a = pf.verts[h], b = pf.verts[nh], ff = oldVertices + pc.faceOf[h];
        if (t == kNoIndex && splitBoundary) {  // [a, M, F(f)], [M, b, F(f)]
            fromFace[h] = k + 2;
            cc.twin[k + 1] = k + 5;
            cc.twin[k + 5] = k + 1;
            toFace[nh] = k + 4;
            appendChildFace(cf, cc, k, {a, edgePoint, ff});
            appendChildFace(cf, cc, k, {edgePoint, b, ff});
            ++edgePoint;
        } else if (t == kNoIndex) {  // [a, b, F(f)]
            toFace[nh] = k + 1;
            fromFace[h] = k + 2;
            appendChildFace(cf, cc, k, {a, b, ff});
        } else {  // [a, F(g), b, F(f)]
            toFace[pc.next[t]] = k;
            fromFace[t] = k + 1;
            toFace[nh] = k + 2;
            fromFace[h] = k + 3;
            appendChildFace(cf, cc, k, {a, oldVertices + pc.faceOf[t], b, ff});
        }
    }
    for (Index c = 0; c < pf.verts.size(); ++c) {
        cc.twin[toFace[c]] = fromFace[c];
        cc.twin[fromFace[c]] = toFace[c];
    }
    // Old vertices keep their kind; a face point is always interior (its fan is the face);
    // an edge point is on the boundary.
    cc.kind.assign(pc.kind.begin(), pc.kind.end());
    cc.kind.resize(oldVertices + pf.faceCount(), VertexKind::Interior);
    cc.kind.resize(cf.vertexCount, VertexKind::Boundary);
    if (consumed) {  // pf and pc are gone from here on
        toFace = {};
        fromFace = {};
        *consumed = Level{};
    }
    completeConnectivity(cf, cc);
    return child;
}

}  // namespace

Level refineLevel(const Level& parent, bool splitBoundary) { return refineLevelFrom(parent, splitBoundary, nullptr); }

Level refineLevel(Level&& parent, bool splitBoundary) { return refineLevelFrom(parent, splitBoundary, &parent); }

Hierarchy refineTopology(Faces input, Connectivity connectivity, bool preprocess, int steps,
                         const std::function<void(int, double)>& onLevel, Boundary boundary) {
    Hierarchy hierarchy;
    hierarchy.preprocessed = preprocess;
    hierarchy.boundary = boundary;
    hierarchy.levels.push_back({std::move(input), std::move(connectivity)});
    const int total = steps + (preprocess ? 1 : 0);
    for (int level = 1; level <= total; ++level) {
        const auto start = std::chrono::steady_clock::now();
        hierarchy.levels.push_back(refineLevel(hierarchy.levels.back(), hierarchy.splitsBoundary(std::size_t(level))));
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

Counts countsAfterStep(const Counts& c, bool splitBoundary) {
    const std::uint64_t split = splitBoundary ? c.boundaryEdges : 0;
    Counts k;
    k.vertices = c.vertices + c.faces + split;
    k.edges = 2 * c.edges + 2 * split;
    k.faces = c.edges + split;
    k.boundaryEdges = c.boundaryEdges + split;
    k.triangles = c.boundaryEdges + split;
    k.quads = c.edges - c.boundaryEdges;
    return k;
}

Counts countsAfterSteps(const Counts& c, int steps, Boundary boundary, bool preprocessed) {
    if (steps <= 0) return c;
    if (boundary == Boundary::Smooth) {
        Counts k = c;
        for (int step = 1; step <= steps; ++step)
            k = countsAfterStep(k, splitsBoundary(boundary, step - (preprocessed ? 1 : 0)));
        return k;
    }
    const std::uint64_t half = std::uint64_t(1) << (steps - 1);  // 2^(k-1)
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
