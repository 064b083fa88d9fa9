// Catmull-Clark through OpenSubdiv's Far API, for side-by-side comparison with P-S.
#include "psub/catmark.h"

#include <opensubdiv/far/error.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/stencilTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <algorithm>
#include <cassert>
#include <memory>

namespace psub {
namespace {

using namespace OpenSubdiv;

struct Point3f {  // a float xyz primvar, laid out as 3 packed floats
    float p[3];
    void Clear() { p[0] = p[1] = p[2] = 0; }
    void AddWithWeight(const Point3f& src, float weight) {
        for (int i = 0; i < 3; ++i) p[i] += weight * src.p[i];
    }
};
static_assert(sizeof(Point3f) == 12);

struct Point3 {
    double p[3];
    void Clear() { p[0] = p[1] = p[2] = 0; }
    void AddWithWeight(const Point3& src, float weight) {
        for (int i = 0; i < 3; ++i) p[i] += weight * src.p[i];
    }
};

// OpenSubdiv prints its errors and warnings on stdout unless given callbacks: keep the last
// error of this thread for the exception instead.
thread_local std::string lastOsdError;

void keepError(Far::ErrorType, const char* message) { lastOsdError = message ? message : ""; }
void dropWarning(const char*) {}

// Faces or vertices with this many corners or incident faces are beyond OpenSubdiv's local
// indices (Far::VALENCE_LIMIT; a boundary vertex has one more edge than faces).
constexpr std::size_t kOsdLimit = std::size_t(Far::VALENCE_LIMIT) - 1;

std::unique_ptr<Far::TopologyRefiner> makeRefiner(const Faces& faces) {
    static const bool callbacksSet = [] {  // once: setting them is not thread-safe
        Far::SetErrorCallback(&keepError);
        Far::SetWarningCallback(&dropWarning);
        return true;
    }();
    (void)callbacksSet;
    lastOsdError.clear();
    std::vector<int> sizes(faces.faceCount());
    for (Index f = 0; f < faces.faceCount(); ++f) sizes[f] = int(faces.faceSize(f));
    Far::TopologyDescriptor descriptor;
    descriptor.numVertices = int(faces.vertexCount);
    descriptor.numFaces = int(faces.faceCount());
    descriptor.numVertsPerFace = sizes.data();
    descriptor.vertIndicesPerFace = reinterpret_cast<const Far::Index*>(faces.verts.data());
    Sdc::Options options;
    options.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
    using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
    std::unique_ptr<Far::TopologyRefiner> refiner(
        Factory::Create(descriptor, Factory::Options(Sdc::SCHEME_CATMARK, options)));
    if (!refiner)
        throw InputError("OpenSubdiv could not build a Catmull-Clark refiner for this mesh" +
                         (lastOsdError.empty() ? std::string() : ": " + lastOsdError));
    return refiner;
}

CatmarkLevel readLevel(const Far::TopologyLevel& level) {
    CatmarkLevel out;
    out.faces.vertexCount = Index(level.GetNumVertices());
    for (int f = 0; f < level.GetNumFaces(); ++f) {
        const Far::ConstIndexArray corners = level.GetFaceVertices(f);
        out.faces.addFace({reinterpret_cast<const Index*>(&corners[0]), std::size_t(corners.size())});
    }
    out.counts.vertices = Index(level.GetNumVertices());
    out.counts.edges = Index(level.GetNumEdges());
    out.counts.faces = Index(level.GetNumFaces());
    for (int e = 0; e < level.GetNumEdges(); ++e) out.counts.boundaryEdges += level.GetEdgeFaces(e).size() == 1;
    for (int f = 0; f < level.GetNumFaces(); ++f) {
        out.counts.triangles += level.GetFaceVertices(f).size() == 3;
        out.counts.quads += level.GetFaceVertices(f).size() == 4;
    }
    return out;
}

}  // namespace

std::optional<std::string> catmarkProblem(const Mesh& mesh) {
    const Faces& faces = mesh.faces;
    const std::string limit = "beyond OpenSubdiv's limit of " + std::to_string(kOsdLimit);
    for (Index f = 0; f < faces.faceCount(); ++f)
        if (faces.faceSize(f) > kOsdLimit)
            return describeFace(mesh.source, f) + ": " + std::to_string(faces.faceSize(f)) + " corners, " + limit;
    std::vector<std::size_t> incident(faces.vertexCount, 0);
    for (Index v : faces.verts)
        if (v < faces.vertexCount && ++incident[v] == kOsdLimit)
            return describeVertex(mesh.source, v) + ": in " + std::to_string(kOsdLimit) + " or more faces, " + limit;
    return std::nullopt;
}

std::vector<CatmarkLevel> refineCatmark(const Faces& faces, std::span<const double> positions,
                                        int levels, bool withPositions) {
    std::unique_ptr<Far::TopologyRefiner> refiner = makeRefiner(faces);
    Far::TopologyRefiner::UniformOptions options(levels);
    options.fullTopologyInLastLevel = true;
    refiner->RefineUniform(options);

    std::vector<CatmarkLevel> out;
    for (int k = 0; k <= levels; ++k) out.push_back(readLevel(refiner->GetLevel(k)));
    if (!withPositions) return out;
    std::vector<Point3> current(faces.vertexCount);
    for (Index v = 0; v < faces.vertexCount; ++v)
        for (int i = 0; i < 3; ++i) current[v].p[i] = positions[3 * v + i];
    out[0].positions.assign(positions.begin(), positions.end());
    Far::PrimvarRefiner primvar(*refiner);
    for (int k = 1; k <= levels; ++k) {
        std::vector<Point3> child(std::size_t(refiner->GetLevel(k).GetNumVertices()));
        Point3* src = current.data();
        Point3* dst = child.data();
        primvar.Interpolate(k, src, dst);
        for (const Point3& point : child) out[k].positions.insert(out[k].positions.end(), point.p, point.p + 3);
        current = std::move(child);
    }
    return out;
}

struct CatmarkStencils::Impl {
    int levels = 0;
    Faces finest;
    std::unique_ptr<const Far::StencilTable> table;  // null for 0 levels (the identity)
};

CatmarkStencils::CatmarkStencils(const Faces& faces, int levels) : impl_(std::make_unique<Impl>()) {
    std::unique_ptr<Far::TopologyRefiner> refiner = makeRefiner(faces);
    Far::TopologyRefiner::UniformOptions uniform(levels);
    uniform.fullTopologyInLastLevel = true;
    refiner->RefineUniform(uniform);
    impl_->levels = levels;
    impl_->finest = readLevel(refiner->GetLevel(levels)).faces;
    if (levels == 0) return;
    Far::StencilTableFactory::Options options;
    options.generateIntermediateLevels = false;  // the finest level only, factorized from the control points
    options.generateOffsets = true;
    impl_->table.reset(Far::StencilTableFactory::Create(*refiner, options));
}

CatmarkStencils::~CatmarkStencils() = default;

const Faces& CatmarkStencils::finestFaces() const { return impl_->finest; }
std::uint32_t CatmarkStencils::refinedCount() const { return impl_->finest.vertexCount; }

void CatmarkStencils::evaluate(std::span<const float> control, std::span<float> refined) const {
    assert(refined.size() >= 3 * std::size_t(refinedCount()));
    if (!impl_->table) {
        std::copy_n(control.begin(), std::min(control.size(), refined.size()), refined.begin());
        return;
    }
    impl_->table->UpdateValues(reinterpret_cast<const Point3f*>(control.data()), reinterpret_cast<Point3f*>(refined.data()));
}

}  // namespace psub
