// OpenSubdiv's side of the benchmark: Far::TopologyRefinerFactory + RefineUniform +
// Far::StencilTableFactory (factorized and per-level "cascading" tables), evaluated by
// Osd::CpuEvaluator and Osd::OmpEvaluator on raw float pointers in 3- and 4-float layouts.
#include "detail.h"

#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/stencilTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>
#include <opensubdiv/osd/bufferDescriptor.h>
#include <opensubdiv/osd/cpuEvaluator.h>
#include <opensubdiv/osd/ompEvaluator.h>

#include <omp.h>

#include <memory>
#include <stdexcept>

namespace psub::bench::detail {
namespace {

using namespace OpenSubdiv;

std::unique_ptr<Far::TopologyRefiner> makeRefiner(const Mesh& mesh) {
    const Faces& faces = mesh.faces;
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
    if (!refiner) throw InputError("OpenSubdiv could not build a Catmull-Clark refiner for this mesh");
    return refiner;
}

enum class Kernel { Cpu, Omp };

// One call of Osd's EvalStencils on rows [start, end) of the given arrays, written from `dst`
// on (row `start` to dst[0]).
void eval(Kernel kernel, const float* src, float* dst, int length, const int* sizes,
          const int* offsets, const int* indices, const float* weights, int start, int end) {
    const Osd::BufferDescriptor desc(0, length, length);
    if (kernel == Kernel::Cpu)
        Osd::CpuEvaluator::EvalStencils(src, desc, dst, desc, sizes, offsets, indices, weights, start, end);
    else
        Osd::OmpEvaluator::EvalStencils(src, desc, dst, desc, sizes, offsets, indices, weights, start, end);
}

// A stencil table in the form the evaluator needs, with per-level row ranges for cascading.
struct Table {
    std::unique_ptr<const Far::StencilTable> table;
    std::vector<int> levelRows;  // rows per level (one entry for a factorized table)
    bool cascading = false;
    int controlCount = 0, finestCount = 0;

    int rows() const { return table->GetNumStencils(); }
    std::uint64_t entries() const { return table->GetControlIndices().size(); }
    std::uint64_t bytes() const { return 8 * std::uint64_t(rows()) + 8 * entries(); }  // sizes, offsets, indices, weights

    // Floats in the evaluation buffer: control points then every level (cascading), or the
    // finest level alone in its own buffer (factorized).
    std::size_t destinationVertices() const {
        std::size_t n = 0;
        for (int r : levelRows) n += std::size_t(r);
        return n;
    }

    // One frame: `buffer` holds the control points at its start (cascading: followed by
    // every level, back to back); factorized tables write `out`.
    void evaluate(Kernel kernel, float* buffer, float* out, int length) const {
        const int* sizes = table->GetSizes().data();
        const int* offsets = table->GetOffsets().data();
        const int* indices = table->GetControlIndices().data();
        const float* weights = table->GetWeights().data();
        if (!cascading) {
            eval(kernel, buffer, out, length, sizes, offsets, indices, weights, 0, rows());
            return;
        }
        // Cascading: each level's indices number the previous level's vertices, so one call
        // per level, its source the previous level, each level passed as a table of its own
        // starting at row 0. The kernels read a table differently (measured on Debian's 3.5):
        // CpuEvaluator walks sizes, indices and weights in step and ignores offsets from row 0
        // (its 4-float path writes wrong rows when `start` is above 0), so all four arrays are
        // advanced; OmpEvaluator reads each row at indices + offsets[row], so only sizes and
        // offsets are.
        int first = 0;
        std::size_t sourceBase = 0, destinationBase = std::size_t(controlCount);
        for (int count : levelRows) {
            const float* src = buffer + sourceBase * std::size_t(length);
            float* dst = buffer + destinationBase * std::size_t(length);
            const std::size_t entry = kernel == Kernel::Cpu ? std::size_t(offsets[first]) : 0;
            eval(kernel, src, dst, length, sizes + first, offsets + first, indices + entry, weights + entry, 0,
                 count);
            sourceBase = destinationBase;
            destinationBase += std::size_t(count);
            first += count;
        }
    }
};

Table buildTable(const Far::TopologyRefiner& refiner, bool cascading) {
    Far::StencilTableFactory::Options options;
    options.generateOffsets = true;  // the raw-pointer kernels need offsets
    if (cascading) {
        options.generateIntermediateLevels = true;
        options.factorizeIntermediateLevels = false;
    } else {
        // The finest level only, from the control points: what Osd::Mesh builds for uniform
        // refinement (the factory's default also keeps every intermediate level).
        options.generateIntermediateLevels = false;
    }
    Table t;
    t.table.reset(Far::StencilTableFactory::Create(refiner, options));
    t.cascading = cascading;
    const int levels = refiner.GetMaxLevel();
    t.controlCount = refiner.GetLevel(0).GetNumVertices();
    t.finestCount = refiner.GetLevel(levels).GetNumVertices();
    if (cascading)
        for (int k = 1; k <= levels; ++k) t.levelRows.push_back(refiner.GetLevel(k).GetNumVertices());
    else
        t.levelRows.push_back(t.finestCount);
    if (std::size_t(t.rows()) != t.destinationVertices())
        throw std::logic_error("OpenSubdiv stencil table has an unexpected row count");
    return t;
}

// Bytes a frame moves (see README): table + each pass's source vertices read once +
// destination vertices written once, at `length` floats per vertex.
std::uint64_t bytesPerFrame(const Table& t, const Far::TopologyRefiner& refiner, int length) {
    std::uint64_t vertices = 0;
    if (t.cascading) {
        for (int k = 1; k <= refiner.GetMaxLevel(); ++k)
            vertices += std::uint64_t(refiner.GetLevel(k - 1).GetNumVertices()) +
                        std::uint64_t(refiner.GetLevel(k).GetNumVertices());
    } else {
        vertices = std::uint64_t(t.controlCount) + std::uint64_t(t.finestCount);
    }
    return t.bytes() + 4 * std::uint64_t(length) * vertices;
}

}  // namespace

Shape runOpenSubdiv(const Mesh& mesh, const std::string& model, int level, const OsdContext& context,
                    std::vector<Record>& records) {
    std::unique_ptr<Far::TopologyRefiner> refiner;
    int topologyRepetitions = 0;
    const double topologyMs = timeBuild(
        [&] {
            refiner.reset();
            refiner = makeRefiner(mesh);
            refiner->RefineUniform(Far::TopologyRefiner::UniformOptions(level));
        },
        topologyRepetitions);

    const Far::TopologyLevel& finest = refiner->GetLevel(level);
    const std::size_t controlCount = std::size_t(refiner->GetLevel(0).GetNumVertices());
    const std::size_t refinedCount = std::size_t(finest.GetNumVertices());
    const Animation animation(mesh.positions, boxDiagonal(mesh.positions));

    // Finest faces as CSR rows, for the shape.
    std::vector<std::uint64_t> faceOffsets{0};
    std::vector<int> faceVerts;
    for (int f = 0; f < finest.GetNumFaces(); ++f) {
        const Far::ConstIndexArray corners = finest.GetFaceVertices(f);
        for (int c = 0; c < corners.size(); ++c) faceVerts.push_back(corners[c]);
        faceOffsets.push_back(faceVerts.size());
    }

    std::vector<float> reference;  // rest pose, xyz, from the first configuration
    Shape shape;
    const int allThreads = context.allThreads;
    struct Config {
        const char* name;
        Kernel kernel;
        int threads;
    };
    std::vector<Config> configs{{"osd-cpu", Kernel::Cpu, 1}, {"osd-omp", Kernel::Omp, 1}};
    if (allThreads > 1) configs.push_back({"osd-omp", Kernel::Omp, allThreads});

    for (bool cascading : {false, true}) {
        if (context.progress)
            context.progress->show(context.label + ": OpenSubdiv " + (cascading ? "cascading" : "factorized") +
                                   " stencil table");
        Table table;
        int tableRepetitions = 0;
        const double tableMs = timeBuild(
            [&] {
                table = Table{};
                table = buildTable(*refiner, cascading);
            },
            tableRepetitions);
        const std::size_t bufferVertices = cascading ? controlCount + table.destinationVertices() : controlCount;
        std::vector<float> buffer3(3 * bufferVertices), buffer4(4 * bufferVertices);
        std::vector<float> out3(cascading ? 0 : 3 * refinedCount), out4(cascading ? 0 : 4 * refinedCount);
        for (const Config& config : configs) {
            const std::string name = std::string(config.name) + (cascading ? "-cascading" : "");
            Record r;
            r.model = model;
            r.scheme = "cc";
            r.levels = r.ccLevel = level;
            r.refinedFaces = std::uint64_t(finest.GetNumFaces());
            r.refinedVertices = refinedCount;
            r.controlVertices = controlCount;
            r.evaluator = name;
            r.table = cascading ? "cascading" : "factorized";
            r.threads = config.threads;
            r.topologyMs = topologyMs;
            r.tableMs = tableMs;
            r.buildMs = topologyMs + tableMs;
            r.buildRepetitions = std::min(topologyRepetitions, tableRepetitions);
            r.tableBytes = table.bytes();
            r.tableEntries = table.entries();
            if (config.kernel == Kernel::Omp) Osd::OmpEvaluator::SetNumThreads(config.threads);

            auto run = [&](int length, const FrameSettings& settings) {
                std::vector<float>& buffer = length == 3 ? buffer3 : buffer4;
                std::vector<float>& out = length == 3 ? out3 : out4;
                return timeFrames(
                    settings, [&](int frame) { animation.write(frame, buffer.data(), unsigned(length)); },
                    [&] { table.evaluate(config.kernel, buffer.data(), out.data(), length); });
            };
            // Layout: OpenSubdiv's kernels have fast paths for 4 and 8 floats only. A short
            // probe of each, then the full measurement in the faster one.
            FrameSettings probe = context.frames;
            probe.warmup = 1;
            probe.frames = std::min(context.frames.frames, 5);
            probe.minFrames = 1;
            probe.budgetSeconds = context.frames.budgetSeconds / 6;
            probe.coldFrames = 0;
            if (context.progress) context.progress->show(context.label + ": " + name + " " +
                                                         std::to_string(config.threads) + " thr, layout probe");
            r.probe3 = run(3, probe).median;
            r.probe4 = run(4, probe).median;
            r.layoutFloats = r.probe4 < r.probe3 ? 4 : 3;
            if (context.progress)
                context.progress->show(context.label + ": " + name + " " + std::to_string(config.threads) +
                                       " thr, " + std::to_string(r.layoutFloats) + "-float layout");
            r.timing = run(r.layoutFloats, context.frames);
            r.bytesPerFrame = bytesPerFrame(table, *refiner, r.layoutFloats);

            // The rest pose once more, in both layouts, checked against the first result.
            for (int length : {3, 4}) {
                std::vector<float>& buffer = length == 3 ? buffer3 : buffer4;
                animation.writeRest(buffer.data(), unsigned(length));
                float* out = length == 3 ? out3.data() : out4.data();
                table.evaluate(config.kernel, buffer.data(), out, length);
                const float* result = cascading ? buffer.data() + (bufferVertices - refinedCount) * std::size_t(length)
                                                : out;
                if (reference.empty()) {
                    reference.resize(3 * refinedCount);
                    for (std::size_t v = 0; v < refinedCount; ++v)
                        for (std::size_t a = 0; a < 3; ++a) reference[3 * v + a] = result[v * std::size_t(length) + a];
                    shape = measureShape(std::span<const std::uint64_t>(faceOffsets), std::span<const int>(faceVerts),
                                         reference.data(), refinedCount, 3);
                }
                const double diff =
                    maxDifference(result, unsigned(length), reference.data(), 3, refinedCount) / shape.diagonal;
                r.maxDiff = std::max(r.maxDiff, diff);
            }
            r.shape = shape;
            if (!(r.maxDiff <= 1e-5) && context.warnings)
                context.warnings->push_back(model + " CC level " + std::to_string(level) + ": " + name + " (" +
                                            std::to_string(config.threads) + " threads) differs from osd-cpu by " +
                                            std::to_string(r.maxDiff) + " of the bounding-box diagonal");
            records.push_back(r);
        }
    }
    Osd::OmpEvaluator::SetNumThreads(allThreads);
    return shape;
}

}  // namespace psub::bench::detail
