// Half-edge connectivity in linear time (counting sorts), vertex classification, validation.
#include "connectivity_detail.h"
#include "psub/topology.h"

#include <algorithm>
#include <cmath>

namespace psub {
namespace {

std::string edgeName(Index a, Index b) {
    return std::to_string(std::uint64_t(a) + 1) + "-" + std::to_string(std::uint64_t(b) + 1);
}

// Stable counting sort of `items` by key(item) in [0, keyCount).
template <class Key>
std::vector<Index> countingSort(const std::vector<Index>& items, Index keyCount, Key key) {
    std::vector<Index> start(std::size_t(keyCount) + 1, 0);
    for (Index item : items) ++start[key(item) + 1];
    for (Index k = 0; k < keyCount; ++k) start[k + 1] += start[k];
    std::vector<Index> sorted(items.size());
    for (Index item : items) sorted[start[key(item)]++] = item;
    return sorted;
}

// Pairs half-edges into twins: half-edges sorted by their undirected edge key (lo, hi), so
// the half-edges of one edge are adjacent, in face order.
void pairTwins(const Faces& faces, Connectivity& c, const Source& source) {
    const Index halfedges = Index(faces.verts.size());
    const auto lo = [&](Index h) { return std::min(faces.verts[h], faces.verts[c.next[h]]); };
    const auto hi = [&](Index h) { return std::max(faces.verts[h], faces.verts[c.next[h]]); };
    std::vector<Index> order(halfedges);
    for (Index h = 0; h < halfedges; ++h) order[h] = h;
    order = countingSort(order, faces.vertexCount, hi);
    order = countingSort(order, faces.vertexCount, lo);

    c.twin.assign(halfedges, kNoIndex);
    for (Index i = 0; i < halfedges;) {
        Index j = i + 1;
        while (j < halfedges && lo(order[j]) == lo(order[i]) && hi(order[j]) == hi(order[i])) ++j;
        const Index first = order[i];
        const Index a = faces.verts[first], b = faces.verts[c.next[first]];
        if (j - i > 2)
            throw InputError(describeFace(source, c.faceOf[order[i + 2]]) + ": edge " +
                             edgeName(a, b) + " is shared by " + std::to_string(j - i) +
                             " faces (non-manifold edge)");
        if (j - i == 2) {
            const Index second = order[i + 1];
            if (faces.verts[second] == a)
                throw InputError(describeFace(source, c.faceOf[second]) + ": edge " +
                                 edgeName(a, b) + " runs the same way as in face " +
                                 std::to_string(std::uint64_t(c.faceOf[first]) + 1) +
                                 " (inconsistent orientation)");
            c.twin[first] = second;
            c.twin[second] = first;
        }
        i = j;
    }
}

Index prevOf(const Faces& faces, const Connectivity& c, Index h) {
    const Index f = c.faceOf[h];
    return h == faces.offsets[f] ? faces.offsets[f + 1] - 1 : h - 1;
}

// Counts the fans of faces around each vertex: walking x -> twin(prev(x)) turns around the
// vertex; an open fan starts at an outgoing boundary half-edge.
void classify(const Faces& faces, Connectivity& c) {
    const Index vertexCount = faces.vertexCount;
    std::vector<bool> visited(faces.verts.size(), false);
    c.kind.assign(vertexCount, VertexKind::Unused);
    for (Index v = 0; v < vertexCount; ++v) {
        const auto out = c.outgoingOf(v);
        if (out.empty()) continue;
        int fans = 0;
        bool open = false;
        auto walk = [&](Index x) {
            ++fans;
            while (!visited[x]) {
                visited[x] = true;
                const Index p = c.twin[prevOf(faces, c, x)];
                if (p == kNoIndex) break;
                x = p;
            }
        };
        for (Index h : out)
            if (c.twin[h] == kNoIndex) {
                open = true;
                walk(h);
            }
        for (Index h : out)
            if (!visited[h]) walk(h);
        c.kind[v] = fans > 1 ? VertexKind::NonManifold
                    : open   ? VertexKind::Boundary
                             : VertexKind::Interior;
    }
}

}  // namespace

void completeConnectivity(const Faces& faces, Connectivity& c) {
    const Index halfedges = Index(faces.verts.size());
    c.edgeOf.assign(halfedges, kNoIndex);
    c.edgeHalfedge.clear();
    std::size_t edges = 0;  // reserved exactly: the largest levels' peak memory is bound by it
    for (Index h = 0; h < halfedges; ++h) edges += c.twin[h] == kNoIndex || h < c.twin[h];
    c.edgeHalfedge.reserve(edges);
    c.boundaryEdgeCount = 0;
    for (Index h = 0; h < halfedges; ++h) {
        if (c.edgeOf[h] != kNoIndex) continue;
        c.edgeOf[h] = c.edgeCount();
        if (c.twin[h] != kNoIndex) c.edgeOf[c.twin[h]] = c.edgeCount();
        else ++c.boundaryEdgeCount;
        c.edgeHalfedge.push_back(h);
    }

    c.outOffsets.assign(std::size_t(faces.vertexCount) + 1, 0);
    for (Index h = 0; h < halfedges; ++h) ++c.outOffsets[faces.verts[h] + 1];
    for (Index v = 0; v < faces.vertexCount; ++v) c.outOffsets[v + 1] += c.outOffsets[v];
    c.outgoing.resize(halfedges);
    std::vector<Index> fill(c.outOffsets.begin(), c.outOffsets.end() - 1);
    for (Index h = 0; h < halfedges; ++h) c.outgoing[fill[faces.verts[h]]++] = h;

    c.valence.assign(faces.vertexCount, 0);
    for (Index h = 0; h < halfedges; ++h) {
        ++c.valence[faces.verts[h]];
        if (c.twin[h] == kNoIndex) ++c.valence[faces.verts[c.next[h]]];
    }
}

Connectivity buildConnectivity(const Faces& faces, const Source& source) {
    Connectivity c;
    const Index halfedges = Index(faces.verts.size());
    c.faceOf.resize(halfedges);
    c.next.resize(halfedges);
    for (Index f = 0; f < faces.faceCount(); ++f)
        for (Index h = faces.offsets[f]; h < faces.offsets[f + 1]; ++h) {
            c.faceOf[h] = f;
            c.next[h] = h + 1 == faces.offsets[f + 1] ? faces.offsets[f] : h + 1;
        }
    pairTwins(faces, c, source);
    completeConnectivity(faces, c);
    classify(faces, c);
    return c;
}

void validateFaces(const Faces& faces, const Source& source) {
    std::vector<Index> seenIn(faces.vertexCount, kNoIndex);
    for (Index f = 0; f < faces.faceCount(); ++f) {
        const auto corners = faces.face(f);
        if (corners.size() < 3)
            throw InputError(describeFace(source, f) + " has " + std::to_string(corners.size()) +
                             " corner" + (corners.size() == 1 ? "" : "s") +
                             "; a face needs at least 3");
        for (Index v : corners) {
            if (v >= faces.vertexCount)
                throw InputError(describeFace(source, f) + ": vertex index " +
                                 std::to_string(std::uint64_t(v) + 1) + " is out of range (" +
                                 std::to_string(faces.vertexCount) + " vertices)");
            if (seenIn[v] == f)
                throw InputError(describeFace(source, f) + " uses vertex " +
                                 std::to_string(std::uint64_t(v) + 1) + " twice");
            seenIn[v] = f;
        }
    }
}

CheckedMesh checkMesh(const Mesh& mesh) {
    const Source& source = mesh.source;
    const std::string name = source.path.empty() ? "mesh" : source.path;
    if (mesh.faces.faceCount() == 0)
        throw InputError(name + ": empty mesh: " +
                         (mesh.faces.vertexCount == 0
                              ? std::string("no vertices and no faces")
                              : std::to_string(mesh.faces.vertexCount) + " vertices but no faces"));
    if (mesh.positions.size() != std::size_t(mesh.faces.vertexCount) * 3)
        throw InputError(name + ": " + std::to_string(mesh.positions.size()) +
                         " coordinates for " + std::to_string(mesh.faces.vertexCount) +
                         " vertices (3 expected per vertex)");
    for (std::size_t i = 0; i < mesh.positions.size(); ++i)
        if (!std::isfinite(mesh.positions[i]))
            throw InputError(describeVertex(source, Index(i / 3)) + ": coordinate " +
                             "xyz"[i % 3] + " is not finite");
    validateFaces(mesh.faces, source);
    checkFaceVarying(mesh);

    CheckedMesh checked{buildConnectivity(mesh.faces, source), {}};
    Index unused = 0, firstUnused = kNoIndex;
    for (Index v = 0; v < mesh.faces.vertexCount; ++v) {
        const VertexKind kind = checked.connectivity.kind[v];
        if (kind == VertexKind::NonManifold)
            checked.warnings.push_back(describeVertex(source, v) +
                                       " is non-manifold (separate fans of faces meet there); "
                                       "it is retained like a boundary vertex");
        if (kind == VertexKind::Unused && unused++ == 0) firstUnused = v;
    }
    if (unused > 0)
        checked.warnings.push_back(name + ": " + std::to_string(unused) + (unused == 1 ? " vertex is" : " vertices are") + " used by no face (first: " +
                                   describeVertex(source, firstUnused) +
                                   "); kept unchanged at every level");
    return checked;
}

VertexClasses classifyVertices(const Connectivity& c) {
    VertexClasses classes;
    for (std::size_t v = 0; v < c.kind.size(); ++v) {
        const Index n = c.valence[v];
        bool regular = false;
        switch (c.kind[v]) {
        case VertexKind::Unused: ++classes.unused; continue;
        case VertexKind::NonManifold: ++classes.nonManifold; break;
        case VertexKind::Boundary: ++classes.boundary; regular = n == 2 || n == 3; break;
        case VertexKind::Interior: regular = n == 4; break;
        }
        ++(regular ? classes.regular : classes.extraordinary);
    }
    return classes;
}

}  // namespace psub
