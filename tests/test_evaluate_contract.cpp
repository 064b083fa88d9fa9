// The evaluator contract (psub/evaluate.h): every backend built from a refinement's tables and
// a form gives, through the same evaluate(), the results of the CPU evaluator used directly;
// surface() is the drawing order of the form; the rules of the header hold.
#include "psub/evaluate.h"
#include "psub/stencils.h"
#if PSUB_HAVE_VULKAN
#include "vulkan_test_support.h"
#endif

#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace psub {
namespace {

struct Case {
    test::Loaded loaded;
    Refinement r;
    std::vector<float> control;
};

Case refined(const std::string& path, int levels) {
    Case c{test::load(path), {}, {}};
    RefineOptions options;
    options.levels = levels;
    options.factorized = true;
    options.tiled = true;
    c.r = refine(c.loaded.mesh, c.loaded.checked.connectivity, options);
    for (double x : c.loaded.mesh.positions) c.control.push_back(float(x));
    return c;
}

// The direct CPU evaluator's positions and normals (one call, as the backend makes it), for
// comparison.
void direct(const Case& c, TableForm form, std::vector<float>& positions, std::vector<float>& normals) {
    auto cpu = form == TableForm::Tiled ? std::make_unique<CpuEvaluator<float>>(c.r.tiled)
                                        : std::make_unique<CpuEvaluator<float>>(c.r.perLevel, c.r.factorized, c.r.surface, form);
    positions.assign(3 * std::size_t(cpu->refinedCount()), 0.0f);
    normals.assign(positions.size(), 0.0f);
    cpu->evaluate(c.control, positions, normals);  // the tiled form: normals in its tile pass
}

float largestDifference(const std::vector<float>& a, const std::vector<float>& b) {
    float worst = a.size() == b.size() ? 0.0f : INFINITY;
    for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
    return worst;
}

// The contract's checks, for any backend: sizes, the same numbers as the direct CPU evaluator
// (within `tolerance`), the drawing order of the form, results without a refined span.
void checkBackend(Evaluator& e, const Case& c, TableForm form, float tolerance) {
    std::vector<float> expected, expectedNormals;
    direct(c, form, expected, expectedNormals);
    ASSERT_EQ(e.controlCount(), c.loaded.mesh.faces.vertexCount);
    ASSERT_EQ(3 * std::size_t(e.refinedCount()), expected.size());
    const SurfaceTable& drawn = form == TableForm::Tiled ? c.r.tiled.surface : c.r.surface;
    EXPECT_EQ(&e.surface(), &drawn);
    EXPECT_EQ(e.surface().vertexCount, e.refinedCount());
    EXPECT_FALSE(e.device().empty());

    std::vector<float> positions(expected.size(), NAN), normals(expected.size(), NAN);
    e.evaluate(c.control, positions, normals);
    EXPECT_LE(largestDifference(positions, expected), tolerance);
    EXPECT_LE(largestDifference(normals, expectedNormals), 10 * tolerance);
    const StageTimes t = e.lastTimes();
    EXPECT_GE(t.evaluateMs + t.normalsMs + t.uploadMs, 0.0);

    std::vector<float> onlyPositions(expected.size(), NAN);  // normals on request only
    e.evaluate(c.control, onlyPositions);
    EXPECT_LE(largestDifference(onlyPositions, expected), tolerance);
    std::vector<float> onlyNormals(expected.size(), NAN);  // positions kept by the backend
    e.evaluate(c.control, {}, onlyNormals);
    EXPECT_LE(largestDifference(onlyNormals, expectedNormals), 10 * tolerance);
}

TEST(EvaluateContract, CpuBackendEveryFormMatchesTheDirectEvaluator) {
    const Case c = refined(test::dataPath("spot_control_mesh.obj"), 3);
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized, TableForm::Tiled}) {
        SCOPED_TRACE(int(form));
        const std::unique_ptr<Evaluator> e = makeCpuEvaluator(tablesOf(c.r), form, 2);
        checkBackend(*e, c, form, 0.0f);  // the same code underneath: equal bits
        EXPECT_EQ(e->device(), "CPU, 2 threads");
    }
}

TEST(EvaluateContract, CpuBackendRefusesShortSpans) {
    const Case c = refined(test::dataPath("cube.obj"), 2);
    const std::unique_ptr<Evaluator> e = makeCpuEvaluator(tablesOf(c.r), TableForm::PerLevel);
    std::vector<float> shortRefined(3 * std::size_t(e->refinedCount()) - 1);
    EXPECT_THROW(e->evaluate(c.control, shortRefined), std::invalid_argument);
    EXPECT_THROW(e->evaluate(std::span<const float>(c.control).first(3), {}), std::invalid_argument);
}

TEST(EvaluateContract, TiledDrawingOrderIsTheTiledSurface) {
    // The tiled form draws its own faces: they differ from the canonical ones in order.
    const Case c = refined(test::dataPath("spot_control_mesh.obj"), 4);
    ASSERT_GT(c.r.tiled.tileCount(), 0u);
    const std::unique_ptr<Evaluator> tiled = makeCpuEvaluator(tablesOf(c.r), TableForm::Tiled);
    const std::unique_ptr<Evaluator> perLevel = makeCpuEvaluator(tablesOf(c.r), TableForm::PerLevel);
    EXPECT_EQ(tiled->surface().faceOffsets.size(), perLevel->surface().faceOffsets.size());
    EXPECT_NE(tiled->surface().faceVerts, perLevel->surface().faceVerts);
}

#if PSUB_HAVE_VULKAN
TEST(EvaluateContract, VulkanBackendEveryFormMatchesTheCpu) {
    std::unique_ptr<VulkanContext> context;
    test::makeContextOrSkip(context);  // validation on, synchronization validation too
    if (!context) return;
    const Case c = refined(test::dataPath("spot_control_mesh.obj"), 4);
    ASSERT_GT(c.r.tiled.tileCount(), 0u);
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized, TableForm::Tiled}) {
        SCOPED_TRACE(int(form));
        const std::unique_ptr<Evaluator> e = makeVulkanEvaluator(*context, tablesOf(c.r), form);
        checkBackend(*e, c, form, 1e-5f);  // float on both sides; a different summation order
        EXPECT_EQ(e->device(), context->deviceName());
    }
    // The one-line switch from makeCpuEvaluator: a context of its own.
    const std::unique_ptr<Evaluator> owning = makeVulkanEvaluator(tablesOf(c.r), TableForm::PerLevel);
    checkBackend(*owning, c, TableForm::PerLevel, 1e-5f);
    EXPECT_EQ(context->validationMessageCount(), 0u) << context->lastValidationMessage();
}
#endif

}  // namespace
}  // namespace psub
