// Face-varying topology (docs/face-varying.md): checking a channel, its level-0 mesh over
// values, and each refined level's faces over face-varying vertices with seams split. No weights.
#include "psub/topology.h"

#include <cmath>
#include <initializer_list>
#include <map>
#include <utility>
#include <vector>

namespace psub {

void checkFaceVarying(const Mesh& mesh) {
    const FaceVarying& uv = mesh.uv;
    if (uv.empty()) return;
    const std::string name = mesh.source.path.empty() ? "mesh" : mesh.source.path;
    if (uv.width < 1 || uv.width > 4)
        throw InputError(name + ": face-varying width " + std::to_string(uv.width) + " (1 to 4 expected)");
    if (uv.corners.size() != mesh.faces.verts.size())
        throw InputError(name + ": " + std::to_string(uv.corners.size()) + " texture-coordinate indices for " +
                         std::to_string(mesh.faces.verts.size()) + " face corners (one per corner expected)");
    if (uv.values.size() % uv.width != 0)
        throw InputError(name + ": " + std::to_string(uv.values.size()) + " texture-coordinate numbers, not a multiple of the width " +
                         std::to_string(uv.width));
    const Index count = uv.valueCount();
    for (std::size_t i = 0; i < uv.values.size(); ++i)
        if (!std::isfinite(uv.values[i])) {
            const std::size_t value = i / uv.width;
            const std::string line = value < uv.valueLine.size() ? ":" + std::to_string(uv.valueLine[value]) : "";
            throw InputError(name + line + ": texture coordinate " + std::to_string(value + 1) + " is not finite");
        }
    std::vector<Index> vertexOf(count, kNoIndex);
    for (Index f = 0; f < mesh.faces.faceCount(); ++f)
        for (Index h = mesh.faces.offsets[f]; h < mesh.faces.offsets[f + 1]; ++h) {
            const Index value = uv.corners[h], v = mesh.faces.verts[h];
            if (value >= count)
                throw InputError(describeFace(mesh.source, f) + ": texture-coordinate index " +
                                 std::to_string(std::uint64_t(value) + 1) + " is out of range (" +
                                 std::to_string(count) + " texture coordinates)");
            if (vertexOf[value] != kNoIndex && vertexOf[value] != v)
                throw InputError(describeFace(mesh.source, f) + ": texture coordinate " +
                                 std::to_string(std::uint64_t(value) + 1) + " is named at vertex " +
                                 std::to_string(std::uint64_t(v) + 1) + " and at vertex " +
                                 std::to_string(std::uint64_t(vertexOf[value]) + 1) +
                                 "; a texture coordinate must belong to one vertex");
            vertexOf[value] = v;
        }
}

void separateSharedValues(Mesh& mesh) {
    FaceVarying& uv = mesh.uv;
    if (uv.empty() || uv.width == 0) return;
    const Index count = uv.valueCount();
    std::vector<Index> vertexOf(count, kNoIndex);
    std::map<std::pair<Index, Index>, Index> copies;  // (value, vertex) -> its copy
    for (std::size_t h = 0; h < uv.corners.size() && h < mesh.faces.verts.size(); ++h) {
        const Index value = uv.corners[h], v = mesh.faces.verts[h];
        if (value >= count) continue;
        if (vertexOf[value] == kNoIndex) vertexOf[value] = v;
        if (vertexOf[value] == v) continue;
        const auto [copy, fresh] = copies.try_emplace({value, v}, uv.valueCount());
        if (fresh) {
            for (std::uint32_t k = 0; k < uv.width; ++k) uv.values.push_back(uv.values[std::size_t(value) * uv.width + k]);
            if (value < uv.valueLine.size()) uv.valueLine.push_back(uv.valueLine[value]);
        }
        uv.corners[h] = copy->second;
    }
}

FaceVaryingLevel faceVaryingBase(const Mesh& mesh, const Connectivity& c) {
    FaceVaryingLevel level;
    level.faces.vertexCount = mesh.uv.valueCount();
    level.faces.offsets = mesh.faces.offsets;
    level.faces.verts = mesh.uv.corners;
    level.connectivity = buildConnectivity(level.faces, mesh.source);
    level.positionOf = mesh.faces.verts;
    level.split.assign(mesh.faces.faceCount(), 0);
    level.faceOf = c.faceOf;
    level.valueFrom = mesh.uv.corners;
    level.valueTo.resize(mesh.uv.corners.size());
    for (Index h = 0; h < level.valueTo.size(); ++h) level.valueTo[h] = mesh.uv.corners[c.next[h]];
    return level;
}

namespace {

// Appends a face-varying face: its values, the position vertex of each corner, whether split.
void addFace(FaceVaryingLevel& level, std::initializer_list<Index> values, std::initializer_list<Index> positions,
             bool split) {
    level.faces.verts.insert(level.faces.verts.end(), values);
    level.faces.offsets.push_back(Index(level.faces.verts.size()));
    level.positionOf.insert(level.positionOf.end(), positions);
    level.split.push_back(split ? 1 : 0);
}

}  // namespace

FaceVaryingLevel refineFaceVarying(const FaceVaryingLevel& parent, const Level& positions) {
    const Faces& pf = positions.faces;
    const Connectivity& pc = positions.connectivity;
    const Index oldPositions = pf.vertexCount, oldValues = parent.faces.vertexCount;
    FaceVaryingLevel child;
    child.faces.vertexCount = oldValues + parent.faces.faceCount();
    const std::size_t halfedges = 4 * std::size_t(pc.edgeCount() - pc.boundaryEdgeCount) + 3 * std::size_t(pc.boundaryEdgeCount);
    child.faceOf.reserve(halfedges);
    child.valueFrom.reserve(halfedges);
    child.valueTo.reserve(halfedges);
    // Child position half-edges in refineLevel's order, each with its face-varying face and ends.
    const auto halfedge = [&child](Index from, Index to) {
        child.faceOf.push_back(child.faces.faceCount() - 1);
        child.valueFrom.push_back(from);
        child.valueTo.push_back(to);
    };
    for (Index h : pc.edgeHalfedge) {
        const Index t = pc.twin[h];
        const Index a = pf.verts[h], b = pf.verts[pc.next[h]];
        const Index pointF = oldPositions + pc.faceOf[h], valueF = oldValues + parent.faceOf[h];
        const Index aF = parent.valueFrom[h], bF = parent.valueTo[h];
        if (t == kNoIndex) {  // [a, b, F(f)]
            addFace(child, {aF, bF, valueF}, {a, b, pointF}, false);
            halfedge(aF, bF);
            halfedge(bF, valueF);
            halfedge(valueF, aF);
            continue;
        }
        const Index pointG = oldPositions + pc.faceOf[t], valueG = oldValues + parent.faceOf[t];
        const Index aG = parent.valueTo[t], bG = parent.valueFrom[t];
        if (!parent.seam(h, t)) {  // [a, F(g), b, F(f)]
            addFace(child, {aF, valueG, bF, valueF}, {a, pointG, b, pointF}, false);
            halfedge(aF, valueG);
            halfedge(valueG, bF);
            halfedge(bF, valueF);
            halfedge(valueF, aF);
            continue;
        }
        // Split along the seam: [a, b, F(f)] on f's side, [b, a, F(g)] on g's side. The
        // position face's half-edges a->F(g), F(g)->b lie in g's triangle, b->F(f), F(f)->a in f's.
        addFace(child, {aF, bF, valueF}, {a, b, pointF}, true);
        addFace(child, {bG, aG, valueG}, {b, a, pointG}, true);
        halfedge(aG, valueG);
        halfedge(valueG, bG);
        child.faceOf.back() = child.faceOf[child.faceOf.size() - 2] = child.faces.faceCount() - 1;
        halfedge(bF, valueF);
        halfedge(valueF, aF);
        child.faceOf.back() = child.faceOf[child.faceOf.size() - 2] = child.faces.faceCount() - 2;
    }
    child.connectivity = buildConnectivity(child.faces);
    return child;
}

}  // namespace psub
