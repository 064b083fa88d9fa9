// Local meshes around a vertex of valence n, grid keys through refinement, and the local
// subdivision matrices of P-S (engine tables, two steps) and Catmull-Clark (OpenSubdiv, one).
#include "local_detail.h"

#include "psub/analysis.h"
#include "psub/stencils.h"

#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/stencilTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>

namespace psub {
namespace detail {
namespace {

// (i, j) of `key` in the frame of sector s, when the point lies on that sector's grid.
std::optional<std::pair<int, int>> inFrame(const GridKey& key, int s, int n) {
    if (!key.valid()) return std::nullopt;
    if (key.i == 0 && key.j == 0) return std::pair{0, 0};
    if (key.sector == s) return std::pair{key.i, key.j};
    if (key.i == 0 && key.sector == (s + n - 1) % n) return std::pair{key.j, 0};
    return std::nullopt;
}

}  // namespace

GridKey canonical(int s, int i, int j, int n) {
    if (i == 0 && j == 0) return {0, 0, 0};
    if (j == 0) return {(s + n - 1) % n, 0, i};
    return {s, i, j};
}

std::uint64_t packKey(const GridKey& key) {
    return (std::uint64_t(std::uint32_t(key.sector)) << 42) | (std::uint64_t(std::uint32_t(key.i)) << 21) |
           std::uint64_t(std::uint32_t(key.j));
}

// The key of the midpoint of grid edge a-b on the grid of half the unit, or invalid when a and
// b are not neighbours on the grid.
GridKey edgeKey(const GridKey& a, const GridKey& b, int n) {
    for (int s : {a.sector, b.sector}) {
        const auto pa = inFrame(a, s, n), pb = inFrame(b, s, n);
        if (!pa || !pb) continue;
        if (std::abs(pa->first - pb->first) + std::abs(pa->second - pb->second) != 1) return {};
        return canonical(s, pa->first + pb->first, pa->second + pb->second, n);
    }
    return {};
}

// The key of the centre of a grid quad on the grid of half the unit, or invalid when the
// corners are not a unit square of one sector.
GridKey faceKey(std::span<const GridKey> corners, int n) {
    if (corners.size() != 4) return {};
    for (const GridKey& c : corners)
        if (!c.valid()) return {};
    for (const GridKey& candidate : corners) {
        if (candidate.i < 1 || candidate.j < 1) continue;
        const int s = candidate.sector;
        int loI = 1 << 30, loJ = 1 << 30, sumI = 0, sumJ = 0;
        bool inSector = true;
        for (const GridKey& c : corners) {
            const auto p = inFrame(c, s, n);
            if (!p) {
                inSector = false;
                break;
            }
            loI = std::min(loI, p->first);
            loJ = std::min(loJ, p->second);
            sumI += p->first;
            sumJ += p->second;
        }
        if (!inSector || sumI != 4 * loI + 2 || sumJ != 4 * loJ + 2) return {};
        return canonical(s, 2 * loI + 1, 2 * loJ + 1, n);
    }
    return {};
}

std::vector<GridKey> refineKeysTwoSteps(int n, const Faces& level, std::span<const GridKey> keys,
                                        const Faces& child) {
    const Index vertices = level.vertexCount, faces = level.faceCount();
    std::vector<GridKey> out(std::size_t(vertices) + faces + child.faceCount());
    for (Index v = 0; v < vertices; ++v)
        if (keys[v].valid()) out[v] = {keys[v].sector, 2 * keys[v].i, 2 * keys[v].j};
    std::vector<GridKey> corners;
    for (Index f = 0; f < faces; ++f) {
        corners.clear();
        for (Index v : level.face(f)) corners.push_back(keys[v]);
        out[vertices + f] = faceKey(corners, n);
    }
    // Each child face is one edge of `level`: its corners below `vertices` are the edge's ends.
    for (Index g = 0; g < child.faceCount(); ++g) {
        Index ends[2], count = 0;
        for (Index v : child.face(g))
            if (v < vertices && count < 2) ends[count++] = v;
        if (count == 2) out[vertices + faces + g] = edgeKey(keys[ends[0]], keys[ends[1]], n);
    }
    return out;
}

std::vector<GridKey> neighbourhoodKeys(int n, int rings) {
    std::vector<GridKey> keys{{0, 0, 0}};
    for (int ring = 1; ring <= rings; ++ring)
        for (int s = 0; s < n; ++s)
            for (int i = 0; i <= ring; ++i)
                for (int j = 1; j <= ring; ++j)
                    if (std::max(i, j) == ring) keys.push_back({s, i, j});
    return keys;
}

LocalMatrix extractMatrix(int n, int rings, std::span<const GridKey> coarseKeys,
                          std::span<const GridKey> fineKeys, const SparseRowsD& rows, const char* what) {
    LocalMatrix out;
    out.valence = Index(n);
    out.rings = rings;
    out.keys = neighbourhoodKeys(n, rings);
    const std::size_t size = out.keys.size();
    std::unordered_map<std::uint64_t, std::uint32_t> columnOf, fineOf;
    for (std::size_t c = 0; c < size; ++c) columnOf[packKey(out.keys[c])] = std::uint32_t(c);
    std::vector<int> coarseColumn(coarseKeys.size(), -1);
    for (std::size_t v = 0; v < coarseKeys.size(); ++v)
        if (coarseKeys[v].valid() && coarseKeys[v].ring() <= rings) coarseColumn[v] = int(columnOf.at(packKey(coarseKeys[v])));
    for (std::size_t v = 0; v < fineKeys.size(); ++v)
        if (fineKeys[v].valid() && !fineOf.try_emplace(packKey(fineKeys[v]), std::uint32_t(v)).second)
            throw std::logic_error(std::string(what) + ": two refined vertices have the same grid key");
    out.weights.assign(size * size, 0.0);
    for (std::size_t r = 0; r < size; ++r) {
        const auto found = fineOf.find(packKey(out.keys[r]));
        if (found == fineOf.end()) throw std::logic_error(std::string(what) + ": a neighbourhood key was not refined");
        const std::uint32_t fine = found->second;
        double sum = 0;
        for (std::uint64_t e = rows.offsets[fine]; e < rows.offsets[fine + 1]; ++e) {
            const int column = coarseColumn[rows.indices[e]];
            if (column < 0) {
                if (std::abs(rows.weights[e]) > 1e-14)
                    throw std::logic_error(std::string(what) + ": the neighbourhood of " +
                                           std::to_string(rings) + " rings is not invariant");
                continue;
            }
            out.weights[r * size + std::size_t(column)] += rows.weights[e];
            sum += rows.weights[e];
        }
        if (std::abs(sum - 1) > 1e-12)
            throw std::logic_error(std::string(what) + ": a row of the local matrix does not sum to 1");
    }
    return out;
}

void setQuadVertexWeights(PerLevelTable& table, Index valence, VertexWeights weights) {
    for (RowGroup& group : table.groups)
        if (group.kind == RowKind::VertexQuad && group.n == valence)
            std::tie(group.centre, group.edge, group.diagonal) = std::tuple(weights.centre, weights.edge, weights.diagonal);
}

namespace {

// Marks the sources of `level` whose rows are VertexQuad rows of valence n: the corners the
// experimental rule treats as extraordinary.
std::vector<char> extraordinarySources(const PerLevelTable& table, const StencilLevel& level, std::uint32_t n) {
    std::vector<char> marked(level.sourceCount, 0);
    for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
        const RowGroup& group = table.groups[g];
        if (group.kind != RowKind::VertexQuad || group.n != n) continue;
        for (std::uint64_t r = 0; r < group.rowCount; ++r) marked[table.indices[group.indexBegin + r * group.width]] = 1;
    }
    return marked;
}

// One row's weights under `rule` (see ExtendedShapeRule); `weights` holds the table's.
void applyRule(const RowGroup& group, const std::uint32_t* sources, const std::vector<char>& marked,
               const ExtendedShapeRule& rule, std::span<double> weights) {
    if (group.kind == RowKind::VertexQuad && group.n == rule.valence) {
        weights[0] = rule.centre.centre;
        for (std::uint32_t j = 1; j < group.width; ++j) weights[j] = j <= group.n ? rule.centre.edge : rule.centre.diagonal;
    } else if (group.kind == RowKind::FaceQuad) {
        double sum = 0;
        for (std::uint32_t j = 0; j < 4; ++j) sum += weights[j] = marked[sources[j]] ? rule.faceCorner : (1 - rule.faceCorner) / 3;
        for (double& w : weights) w /= sum;
    } else if (group.kind == RowKind::VertexQuad && group.n == 4) {
        for (std::uint32_t j = 1; j <= 4; ++j)
            if (marked[sources[j]]) {
                weights[0] += weights[j] - rule.neighbourCentre;
                weights[j] = rule.neighbourCentre;
            }
    }
}

}  // namespace

SparseRowsD composePerLevel(const PerLevelTable& table, const ExtendedShapeRule* rule) {
    SparseRowsD current;  // control -> control: the identity
    current.offsets.resize(std::size_t(table.controlCount) + 1);
    for (std::uint32_t v = 0; v <= table.controlCount; ++v) current.offsets[v] = v;
    for (std::uint32_t v = 0; v < table.controlCount; ++v) current.indices.push_back(v);
    current.weights.assign(table.controlCount, 1.0);
    for (const StencilLevel& level : table.levels) {
        // Each child row as a list of (parent vertex, weight), then composed with `current`.
        std::vector<std::vector<std::pair<std::uint32_t, double>>> child(level.destinationCount);
        const std::vector<char> marked = rule ? extraordinarySources(table, level, rule->valence) : std::vector<char>{};
        std::vector<double> weights;
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            if (readsOwnLevel(group.kind))
                throw std::invalid_argument("composePerLevel: the table's vertex rows read face points");
            for (std::uint64_t r = 0; r < group.rowCount; ++r) {
                const std::uint32_t* sources = &table.indices[group.indexBegin + r * group.width];
                auto& row = child[table.destinations[group.rowBegin + r]];
                weights.clear();
                for (std::uint32_t j = 0; j < group.width; ++j)
                    weights.push_back(j == 0 ? group.centre : j <= group.n ? group.edge : group.diagonal);
                if (rule) applyRule(group, sources, marked, *rule, weights);
                for (std::uint32_t j = 0; j < group.width; ++j) row.emplace_back(sources[j], weights[j]);
            }
        }
        SparseRowsD next;
        std::vector<double> accumulator(table.controlCount, 0.0);
        std::vector<char> touched(table.controlCount, 0);
        std::vector<std::uint32_t> list;
        for (const auto& row : child) {
            for (const auto& [source, weight] : row)
                for (std::uint64_t e = current.offsets[source]; e < current.offsets[source + 1]; ++e) {
                    const std::uint32_t i = current.indices[e];
                    if (!touched[i]) touched[i] = 1, list.push_back(i);
                    accumulator[i] += weight * current.weights[e];
                }
            std::sort(list.begin(), list.end());
            for (std::uint32_t i : list) {
                next.indices.push_back(i);
                next.weights.push_back(accumulator[i]);
                accumulator[i] = 0;
                touched[i] = 0;
            }
            list.clear();
            next.offsets.push_back(next.indices.size());
        }
        current = std::move(next);
    }
    return current;
}

}  // namespace detail

using namespace detail;

LocalMesh makeLocalMesh(Index valence, int rings, double bump) {
    if (valence < 2 || rings < 1) throw std::invalid_argument("makeLocalMesh: valence >= 2 and rings >= 1");
    const int n = int(valence), R = rings;
    LocalMesh out;
    out.valence = valence;
    out.rings = rings;
    const auto index = [&](int s, int i, int j) -> Index {
        const GridKey k = canonical(s, i, j, n);
        return k.i == 0 && k.j == 0 ? 0 : Index(1 + k.sector * R * (R + 1) + k.i * R + (k.j - 1));
    };
    const Index count = Index(1 + n * R * (R + 1));
    out.keys.resize(count);
    out.mesh.positions.resize(3 * std::size_t(count));
    out.keys[0] = {0, 0, 0};
    for (int s = 0; s < n; ++s)
        for (int i = 0; i <= R; ++i)
            for (int j = 1; j <= R; ++j) {
                const Index v = index(s, i, j);
                out.keys[v] = {s, i, j};
                const double radius = std::hypot(double(i), double(j));
                const double angle = 2 * std::numbers::pi * s / n + std::atan2(double(j), double(i)) * 4 / n;
                const double x = radius * std::cos(angle), y = radius * std::sin(angle);
                out.mesh.positions[3 * v + 0] = x;
                out.mesh.positions[3 * v + 1] = y;
                out.mesh.positions[3 * v + 2] =
                    bump * (std::sin(0.9 * x + 0.4) * std::cos(0.7 * y - 0.3) + 0.3 * x - 0.2 * y + 0.05 * x * y);
            }
    out.mesh.faces.vertexCount = count;
    for (int s = 0; s < n; ++s)
        for (int i = 0; i < R; ++i)
            for (int j = 0; j < R; ++j) {
                const Index quad[4] = {index(s, i, j), index(s, i + 1, j), index(s, i + 1, j + 1), index(s, i, j + 1)};
                out.mesh.faces.addFace(quad);
            }
    // The centre's z is the height field's at the origin, like every other vertex.
    out.mesh.positions[2] = bump * std::sin(0.4) * std::cos(-0.3);
    return out;
}

namespace {

LocalMatrix twoStepMatrix(Index valence, Rules rules, const VertexWeights* centre, int rings) {
    if (rings < 3) throw std::invalid_argument("psTwoStepMatrix: rings >= 3");
    const LocalMesh local = makeLocalMesh(valence, rings + 2);
    const Connectivity connectivity = buildConnectivity(local.mesh.faces);
    const Hierarchy hierarchy = refineTopology(local.mesh.faces, connectivity, false, 2);
    PerLevelTable table = buildPerLevelTable(hierarchy, rules);
    if (centre) detail::setQuadVertexWeights(table, valence, *centre);
    const std::vector<GridKey> fine =
        refineKeysTwoSteps(int(valence), hierarchy.levels[0].faces, local.keys, hierarchy.levels[1].faces);
    return extractMatrix(int(valence), rings, local.keys, fine, composePerLevel(table), "P-S two-step matrix");
}

}  // namespace

LocalMatrix psTwoStepMatrix(Index valence, Rules rules, int rings) {
    return twoStepMatrix(valence, rules, nullptr, rings);
}

LocalMatrix psTwoStepMatrix(const ExtendedShapeRule& rule, int rings) {
    if (rule.valence < 3 || rule.valence == 4) throw std::invalid_argument("psTwoStepMatrix: the rule's valence is 3 or more, not 4");
    if (rings < 3) throw std::invalid_argument("psTwoStepMatrix: rings >= 3");
    const LocalMesh local = makeLocalMesh(rule.valence, rings + 2);
    const Connectivity connectivity = buildConnectivity(local.mesh.faces);
    const Hierarchy hierarchy = refineTopology(local.mesh.faces, connectivity, false, 2);
    const PerLevelTable table = buildPerLevelTable(hierarchy, Rules::Paper);
    const std::vector<GridKey> fine =
        refineKeysTwoSteps(int(rule.valence), hierarchy.levels[0].faces, local.keys, hierarchy.levels[1].faces);
    return extractMatrix(int(rule.valence), rings, local.keys, fine, composePerLevel(table, &rule), "P-S two-step matrix");
}

LocalMatrix psTwoStepMatrix(Index valence, VertexWeights centre, int rings) {
    if (valence == 4) throw std::invalid_argument("psTwoStepMatrix: explicit centre weights need valence != 4");
    return twoStepMatrix(valence, Rules::Paper, &centre, rings);
}

LocalMatrix catmarkOneStepMatrix(Index valence, int rings) {
    using namespace OpenSubdiv;
    if (rings < 1) throw std::invalid_argument("catmarkOneStepMatrix: rings >= 1");
    const LocalMesh local = makeLocalMesh(valence, rings + 2);
    const Faces& faces = local.mesh.faces;
    std::vector<int> sizes(faces.faceCount(), 4);
    Far::TopologyDescriptor descriptor;
    descriptor.numVertices = int(faces.vertexCount);
    descriptor.numFaces = int(faces.faceCount());
    descriptor.numVertsPerFace = sizes.data();
    descriptor.vertIndicesPerFace = reinterpret_cast<const Far::Index*>(faces.verts.data());
    Sdc::Options sdc;
    sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
    using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
    std::unique_ptr<Far::TopologyRefiner> refiner(
        Factory::Create(descriptor, Factory::Options(Sdc::SCHEME_CATMARK, sdc)));
    if (!refiner) throw std::logic_error("OpenSubdiv rejected the local mesh");
    refiner->RefineUniform(Far::TopologyRefiner::UniformOptions(1));
    Far::StencilTableFactoryReal<double>::Options options;
    options.generateIntermediateLevels = false;
    options.generateOffsets = true;
    options.maxLevel = 1;
    std::unique_ptr<const Far::StencilTableReal<double>> stencils(
        Far::StencilTableFactoryReal<double>::Create(*refiner, options));

    // Keys of the refined vertices from OpenSubdiv's own parent-to-child relations.
    const Far::TopologyLevel& coarse = refiner->GetLevel(0);
    std::vector<GridKey> fine(std::size_t(refiner->GetLevel(1).GetNumVertices()));
    const int n = int(valence);
    for (int v = 0; v < coarse.GetNumVertices(); ++v) {
        const GridKey& k = local.keys[std::size_t(v)];
        fine[std::size_t(coarse.GetVertexChildVertex(v))] = {k.sector, 2 * k.i, 2 * k.j};
    }
    for (int e = 0; e < coarse.GetNumEdges(); ++e) {
        const Far::ConstIndexArray ends = coarse.GetEdgeVertices(e);
        fine[std::size_t(coarse.GetEdgeChildVertex(e))] =
            edgeKey(local.keys[std::size_t(ends[0])], local.keys[std::size_t(ends[1])], n);
    }
    for (int f = 0; f < coarse.GetNumFaces(); ++f) {
        const Far::ConstIndexArray corners = coarse.GetFaceVertices(f);
        std::vector<GridKey> cornerKeys;
        for (int c = 0; c < corners.size(); ++c) cornerKeys.push_back(local.keys[std::size_t(corners[c])]);
        fine[std::size_t(coarse.GetFaceChildVertex(f))] = faceKey(cornerKeys, n);
    }
    if (std::size_t(stencils->GetNumStencils()) != fine.size())
        throw std::logic_error("OpenSubdiv's stencil table does not cover level 1");
    SparseRowsD rows;
    for (int s = 0; s < stencils->GetNumStencils(); ++s) {
        const auto stencil = stencils->GetStencil(Far::Index(s));
        for (int e = 0; e < stencil.GetSize(); ++e) {
            rows.indices.push_back(std::uint32_t(stencil.GetVertexIndices()[e]));
            rows.weights.push_back(stencil.GetWeights()[e]);
        }
        rows.offsets.push_back(rows.indices.size());
    }
    return extractMatrix(n, rings, local.keys, fine, rows, "Catmull-Clark one-step matrix");
}

double catmarkSubdominantClosedForm(Index valence) {
    const double n = valence, c = std::cos(2 * std::numbers::pi / n);
    return (5 + c + std::cos(std::numbers::pi / n) * std::sqrt(2 * (9 + c))) / 16;
}

}  // namespace psub
