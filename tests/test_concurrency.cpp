// Several evaluators on different meshes in different threads, and one set of tables shared
// by several threads evaluating different frames, give exactly the serial results. Also run
// under ThreadSanitizer (README: "Reliability").
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <omp.h>

#include <cmath>
#include <tuple>
#include <thread>

namespace psub {
namespace {

struct Model {
    test::Loaded loaded;
    Refinement refinement;
};

Model prepare(const std::string& path, int levels) {
    Model model{test::load(path), {}};
    model.refinement = refine(model.loaded.mesh, model.loaded.checked.connectivity,
                              {levels, Preprocess::Auto, true, {}});
    return model;
}

// Frame `frame` of a wave over the control points.
std::vector<float> frameOf(const Mesh& mesh, int frame) {
    std::vector<float> control(mesh.positions.size());
    for (std::size_t i = 0; i < control.size(); ++i)
        control[i] = float(mesh.positions[i] + (i % 3 == 1 ? 0.1 * std::sin(mesh.positions[i - 1] + frame) : 0.0));
    return control;
}

std::vector<float> evaluateFrame(const Model& m, TableForm form, int frame) {
    CpuEvaluator<float> evaluator(m.refinement.perLevel, m.refinement.factorized, m.refinement.surface, form, 3, 1);
    std::vector<float> out(3 * std::size_t(evaluator.refinedCount()));
    evaluator.evaluate(frameOf(m.loaded.mesh, frame), out);
    return out;
}

TEST(Concurrency, EvaluatorsOnDifferentMeshesInDifferentThreadsMatchSerialRuns) {
    const std::vector<Model> models = {prepare(test::dataPath("cow.obj"), 2),
                                       prepare(test::dataPath("spot_control_mesh.obj"), 4),
                                       prepare(test::dataPath("grid4x4.obj"), 5),
                                       prepare(test::testDataPath("osd-shapes/catmark_pawn.obj"), 3)};
    std::vector<std::vector<float>> serial, parallel(models.size());
    for (const Model& m : models) serial.push_back(evaluateFrame(m, TableForm::PerLevel, 3));
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < models.size(); ++i)
        threads.emplace_back([&, i] { parallel[i] = evaluateFrame(models[i], TableForm::PerLevel, 3); });
    for (std::thread& t : threads) t.join();
    for (std::size_t i = 0; i < models.size(); ++i) EXPECT_EQ(serial[i], parallel[i]) << "model " << i;
}

TEST(Concurrency, OneTableSharedByThreadsEvaluatingDifferentFrames) {
    const Model model = prepare(test::dataPath("spot_control_mesh.obj"), 5);
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) {
        constexpr int kFrames = 6;
        std::vector<std::vector<float>> serial, parallel(kFrames);
        for (int frame = 0; frame < kFrames; ++frame) serial.push_back(evaluateFrame(model, form, frame));
        std::vector<std::thread> threads;
        for (int frame = 0; frame < kFrames; ++frame)
            threads.emplace_back([&, frame] { parallel[std::size_t(frame)] = evaluateFrame(model, form, frame); });
        for (std::thread& t : threads) t.join();
        for (int frame = 0; frame < kFrames; ++frame) EXPECT_EQ(serial[std::size_t(frame)], parallel[std::size_t(frame)]);
    }
}

TEST(Concurrency, RefiningInSeveralThreadsAtOnceGivesIdenticalTables) {
    const auto cow = test::load(test::dataPath("cow.obj"));
    std::vector<Refinement> results(3);
    std::vector<std::thread> threads;
    for (Refinement& r : results)
        threads.emplace_back([&] { r = refine(cow.mesh, cow.checked.connectivity, {2, Preprocess::Auto, true, {}}); });
    for (std::thread& t : threads) t.join();
    for (const Refinement& r : results) {
        EXPECT_EQ(r.perLevel.indices, results[0].perLevel.indices);
        EXPECT_EQ(r.perLevel.destinations, results[0].perLevel.destinations);
        EXPECT_EQ(r.factorized.indices, results[0].factorized.indices);
        EXPECT_EQ(r.factorized.weights, results[0].factorized.weights);
    }
}

// Each step's rows are found and written by runs of child vertices, one run per OpenMP thread
// (at least 32,768 rows a run): the table must not depend on how many runs there were. The
// cow's last step at 5 steps has about 279,000 rows, so 1, 2, 3 and 8 threads cut it into 1,
// 2, 3 and 8 runs. With a boundary (the split rule) and the face-varying channel too.
TEST(Concurrency, TheTableIsTheSameWhateverTheBuildsThreadCount) {
    const auto cow = test::load(test::dataPath("cow.obj"));
    const auto spot = test::load(test::dataPath("spot_control_mesh_uv.obj"));
    const test::OmpThreadsRestored restore;
    for (const auto* model : {&cow, &spot}) {
        for (const Boundary boundary : {Boundary::Paper, Boundary::Smooth}) {
            RefineOptions options{5, Preprocess::Auto, false, {}};
            options.boundary = boundary;
            std::vector<Refinement> results;
            for (const int threads : {1, 2, 3, 8}) {
                omp_set_num_threads(threads);
                results.push_back(refine(model->mesh, model->checked.connectivity, options));
            }
            omp_set_num_threads(restore.found);
            for (const Refinement& r : results) {
                EXPECT_EQ(r.perLevel.indices, results[0].perLevel.indices);
                EXPECT_EQ(r.perLevel.destinations, results[0].perLevel.destinations);
                ASSERT_EQ(r.perLevel.groups.size(), results[0].perLevel.groups.size());
                for (std::size_t g = 0; g < r.perLevel.groups.size(); ++g) {
                    const RowGroup &a = r.perLevel.groups[g], &b = results[0].perLevel.groups[g];
                    EXPECT_EQ(std::tie(a.kind, a.n, a.m, a.rowBegin, a.rowCount, a.indexBegin),
                              std::tie(b.kind, b.n, b.m, b.rowBegin, b.rowCount, b.indexBegin));
                }
                EXPECT_EQ(r.uv.perLevel.indices, results[0].uv.perLevel.indices);
                EXPECT_EQ(r.uv.perLevel.destinations, results[0].uv.perLevel.destinations);
            }
        }
    }
}

}  // namespace
}  // namespace psub
