// The Vulkan evaluator against the CPU evaluator, on lavapipe (or any device) with the
// Khronos validation layer always on: every model, both table forms, widths 3 and 4, changing
// frames, normals; bindings beyond maxStorageBufferRange; empty and zero-level meshes; a
// missing device; evaluators created and destroyed repeatedly. Any validation message fails
// the test that caused it. No device fails too, unless PSUB_ALLOW_NO_VULKAN=1.
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "psub/vulkan_evaluator.h"
#include "test_support.h"
#include "vulkan_test_support.h"

// Internal headers: the context's handles (to provoke a validation error on purpose) and the
// SPIR-V reflection.
#include "device.h"
#include "pipelines.h"
#include "level.spv.h"

#include <gtest/gtest.h>

#include <malloc.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <unistd.h>

namespace psub {
namespace {

using test::kSanitized;
using test::noVulkanAllowed;
using test::validatedVulkanOptions;

// The process's context, validation required; or why there is none.
struct Shared {
    std::unique_ptr<VulkanContext> context;
    std::string error;
};

Shared& shared() {
    static Shared s = [] {
        Shared made;
        try {
            made.context = std::make_unique<VulkanContext>(validatedVulkanOptions());
        } catch (const VulkanError& e) {
            made.error = e.what();
        }
        return made;
    }();
    return s;
}

// Every test: a device or a failure (a skip only when PSUB_ALLOW_NO_VULKAN=1), and no
// validation message from start to end.
class Vulkan : public ::testing::Test {
protected:
    void SetUp() override {
        if (!shared().context) {
            if (noVulkanAllowed()) {
                GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << shared().error;
            }
            FAIL() << "no Vulkan device: " << shared().error << " (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
        }
        ASSERT_TRUE(shared().context->validationEnabled());
        messagesBefore_ = vulkanValidationMessageTotal();
    }
    void TearDown() override {
        if (shared().context) {
            EXPECT_EQ(vulkanValidationMessageTotal(), messagesBefore_)
                << "validation messages; the last: " << shared().context->lastValidationMessage();
        }
    }
    VulkanContext& context() { return *shared().context; }
    void forgetMessages() { messagesBefore_ = vulkanValidationMessageTotal(); }

private:
    std::uint64_t messagesBefore_ = 0;
};

struct Tables {
    test::Loaded loaded;
    PerLevelTable perLevel;
    FactorizedTable factorized;
    SurfaceTable surface;
};

Tables tablesFor(const std::string& path, int steps, bool factorized = true, Boundary boundary = Boundary::Paper,
                 Rules rules = Rules::Paper) {
    Tables t{test::load(path), {}, {}, {}};
    RefineOptions options{steps, Preprocess::Auto, factorized, {}};
    options.boundary = boundary;
    options.rules = rules;
    const Refinement r = refine(t.loaded.mesh, t.loaded.checked.connectivity, options);
    t.perLevel = r.perLevel;
    t.factorized = r.factorized;
    t.surface = r.surface;
    return t;
}

const auto diagonal = test::boundingDiagonal;

using test::animate;

// Largest |a - b| over the values; both the same size.
double maxDifference(const std::vector<float>& a, const std::vector<float>& b) {
    double worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(double(a[i]) - double(b[i])));
    return worst;
}

void expectClose(const std::vector<float>& actual, const std::vector<float>& expected, double tolerance,
                 const std::string& what) {
    ASSERT_EQ(actual.size(), expected.size()) << what;
    for (std::size_t i = 0; i < expected.size(); ++i)
        ASSERT_NEAR(actual[i], expected[i], tolerance) << what << ": value " << i;
}

// Runs `frames` changing frames through a Vulkan evaluator and the CPU evaluator and compares
// positions (relative 1e-5 of the model's size) and normals.
void compareWithCpu(VulkanContext& context, const Tables& t, TableForm form, std::uint32_t width, int frames,
                    const VulkanEvaluatorOptions& options = {}) {
    const std::string what = std::string(form == TableForm::PerLevel ? "per-level" : "factorized") + " width " +
                             std::to_string(width);
    CpuEvaluator<float> cpu(t.perLevel, t.factorized, t.surface, form, width, 2);
    VulkanEvaluator gpu(context, t.perLevel, t.factorized, t.surface, form, width, options);
    ASSERT_EQ(gpu.refinedCount(), cpu.refinedCount());
    const double tolerance = 1e-5 * std::max(1.0, diagonal(t.loaded.mesh.positions));
    const std::size_t refinedFloats = std::size_t(cpu.refinedCount()) * width;
    std::vector<float> expected(refinedFloats), actual(refinedFloats), expectedNormals(3 * std::size_t(cpu.refinedCount())),
        actualNormals(expectedNormals.size());
    for (int frame = 0; frame < frames; ++frame) {
        const std::vector<float> control = animate(t.loaded.mesh.positions, width, frame);
        cpu.evaluate(control, expected);
        cpu.normals(expected, expectedNormals);
        gpu.evaluate(control, actual, actualNormals);
        expectClose(actual, expected, tolerance, what + " frame " + std::to_string(frame));
        expectClose(actualNormals, expectedNormals, 1e-5, what + " normals, frame " + std::to_string(frame));
    }
}

// ---------------------------------------------------------------------------------------

class VulkanModel : public Vulkan, public ::testing::WithParamInterface<std::string> {};

TEST_P(VulkanModel, EqualsTheCpuEvaluatorOverChangingFramesBothFormsWidths3And4) {
    for (int steps : {1, 3})
        for (TableForm form : {TableForm::PerLevel, TableForm::Factorized})
            for (std::uint32_t width : {3u, 4u}) {
                SCOPED_TRACE(GetParam() + " steps " + std::to_string(steps));
                compareWithCpu(context(), tablesFor(GetParam(), steps), form, width, 3);
            }
}

// Rules::Shape's rows carry their weights per group, the corner rule's row kinds included: the
// same kernels carry them (the CPU evaluator is checked against the rule oracle for them in
// test_shape_rules.cpp).
TEST_P(VulkanModel, ShapeRulesEqualTheCpuEvaluatorBothForms) {
    const Tables t = tablesFor(GetParam(), 3, true, Boundary::Paper, Rules::Shape);
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) compareWithCpu(context(), t, form, 3, 2);
}

std::string modelName(const ::testing::TestParamInfo<std::string>& info) {
    std::string name = info.param.substr(info.param.find_last_of('/') + 1);
    name = name.substr(0, name.find('.'));
    for (char& ch : name)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
    return name;
}

INSTANTIATE_TEST_SUITE_P(EveryModel, VulkanModel, ::testing::ValuesIn(test::allValidModels()), modelName);

TEST_F(Vulkan, DeeperLevelsOfTheBundledModelsMatch) {
    for (const auto& [model, steps] : {std::pair{"cow.obj", 4}, std::pair{"spot_control_mesh.obj", 6}}) {
        SCOPED_TRACE(model);
        const Tables t = tablesFor(test::dataPath(model), steps);
        for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) compareWithCpu(context(), t, form, 3, 2);
    }
}

TEST_F(Vulkan, SmoothBoundaryTablesMatchTheCpu) {
    // Boundary::Smooth adds the cubic B-spline boundary rows; the kernels are the same.
    for (const char* model : {"grid4x4.obj", "cube.obj"})
        for (int steps : {1, 4}) {
            SCOPED_TRACE(std::string(model) + " steps " + std::to_string(steps));
            const Tables t = tablesFor(test::dataPath(model), steps, true, Boundary::Smooth);
            for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) compareWithCpu(context(), t, form, 3, 2);
        }
    const Tables suzanne = tablesFor(test::testDataPath("suzanne.obj"), 3, true, Boundary::Smooth);
    compareWithCpu(context(), suzanne, TableForm::PerLevel, 4, 2);
}

TEST_F(Vulkan, PerLevelResultsAreBitIdenticalToTheCpu) {
    // Same operations in the same order, no fused multiply-adds: not just close, equal, in the
    // dispatches of one group (its shape compiled in) as in those of several.
    const Tables t = tablesFor(test::dataPath("cow.obj"), 3);
    // With refine()'s vertex rows from face points: a second stage per level, reading the first's
    // (the cow's extraordinary vertices' rows too, each reading its own destination first).
    for (RowKind kind : {RowKind::VertexFromFacePoints, RowKind::VertexFromCentreAndFacePoints})
        ASSERT_TRUE(std::any_of(t.perLevel.groups.begin(), t.perLevel.groups.end(),
                                [kind](const RowGroup& g) { return g.kind == kind; }));
    CpuEvaluator<float> cpu(t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 3, 2);
    VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 3);
    const std::vector<float> control = animate(t.loaded.mesh.positions, 3, 1);
    std::vector<float> expected(3 * std::size_t(cpu.refinedCount())), actual(expected.size());
    cpu.evaluate(control, expected);
    gpu.evaluate(control, actual);
    EXPECT_EQ(maxDifference(actual, expected), 0.0);
    // The small groups of a level's stage share a dispatch of any shape (the cow's extraordinary
    // vertices, by valence: ten groups a level): at most three dispatches a level (its face
    // points, its other groups, its vertex rows from face points), where each group had its own
    // (41 here).
    EXPECT_LE(gpu.dispatchCount(), 3 * t.perLevel.levels.size());
}

// The per-level table ordered by region (orderLevelsByRegion): the device reads each row's
// destination, so the same bits as the table as refined, whose groups of consecutive
// destinations (each level's face points) hold none: their rows' words are their sources alone,
// so the table as refined takes fewer device bytes.
TEST_F(Vulkan, ARegionOrderedTableGivesTheSameBits) {
    const Tables t = tablesFor(test::dataPath("cow.obj"), 3);
    PerLevelTable ordered = t.perLevel;
    orderLevelsByRegion(ordered, 3);
    VulkanEvaluator asRefined(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 3);
    VulkanEvaluator byRegion(context(), ordered, t.factorized, t.surface, TableForm::PerLevel, 3);
    const std::vector<float> control = animate(t.loaded.mesh.positions, 3, 1);
    std::vector<float> expected(3 * std::size_t(t.perLevel.refinedCount())), actual(expected.size());
    asRefined.evaluate(control, expected);
    byRegion.evaluate(control, actual);
    EXPECT_EQ(actual, expected);
    EXPECT_LT(asRefined.deviceBytes(), byRegion.deviceBytes());
}

TEST_F(Vulkan, StorageBufferAndTexelReadsGiveTheSameResults) {
    // Kernels read inputs and tables through texel buffers where the device allows it;
    // PSUB_VULKAN_TEXELS=0 selects the storage-buffer reads. Both match the CPU (widths 3 and 4,
    // per-level and factorized) and give the very same numbers at width 5 (one value at a time,
    // where the CPU's generic kernel adds in another order).
    const Tables t = tablesFor(test::dataPath("cow.obj"), 3);
    const char* before = std::getenv("PSUB_VULKAN_TEXELS");
    const std::string saved = before ? before : "";
    const std::vector<float> control = animate(t.loaded.mesh.positions, 5, 1);
    std::vector<float> results[2], normals[2];
    for (int texels : {1, 0}) {
        SCOPED_TRACE("PSUB_VULKAN_TEXELS=" + std::to_string(texels));
        ::setenv("PSUB_VULKAN_TEXELS", texels ? "1" : "0", 1);
        for (std::uint32_t width : {3u, 4u})
            for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) compareWithCpu(context(), t, form, width, 2);
        VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 5);
        results[texels].resize(5 * std::size_t(gpu.refinedCount()));
        normals[texels].resize(3 * std::size_t(gpu.refinedCount()));
        gpu.evaluate(control, results[texels], normals[texels]);
    }
    EXPECT_EQ(maxDifference(results[0], results[1]), 0.0);
    EXPECT_EQ(maxDifference(normals[0], normals[1]), 0.0);
    if (before) ::setenv("PSUB_VULKAN_TEXELS", saved.c_str(), 1);
    else ::unsetenv("PSUB_VULKAN_TEXELS");
}

TEST_F(Vulkan, NormalsOfGivenPositionsEqualTheCpuNormals) {
    const Tables t = tablesFor(test::dataPath("spot_control_mesh.obj"), 3);
    for (std::uint32_t width : {3u, 4u}) {
        CpuEvaluator<float> cpu(t.perLevel, t.factorized, t.surface, TableForm::PerLevel, width, 2);
        VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, width);
        std::vector<float> refined(std::size_t(cpu.refinedCount()) * width), expected(3 * std::size_t(cpu.refinedCount())),
            actual(expected.size());
        cpu.evaluate(animate(t.loaded.mesh.positions, width, 2), refined);
        cpu.normals(refined, expected);
        gpu.normals(refined, actual);
        expectClose(actual, expected, 1e-5, "normals");
        // Results left on the device, then normals only.
        std::vector<float> fromDevice(expected.size());
        gpu.evaluate(animate(t.loaded.mesh.positions, width, 2), {}, fromDevice);
        expectClose(fromDevice, expected, 1e-5, "normals of device-resident positions");
    }
}

// The vertex pass's fixed layouts: 8 words a vertex where more than 1 in 64 vertices are in more
// than 4 faces (the cow at 3 steps: 2,785 of 69,649), else 4 (at 5 steps: 2,785 of 278,593);
// either way the vertices in more faces than the layout holds (38, then 2,785) are written again
// from their own rows. Both equal the CPU's normals.
TEST_F(Vulkan, NormalsOfBothVertexLayoutsEqualTheCpuNormals) {
    for (int steps : {3, 5}) {
        SCOPED_TRACE("steps " + std::to_string(steps));
        const Tables t = tablesFor(test::dataPath("cow.obj"), steps);
        CpuEvaluator<float> cpu(t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 3, 2);
        VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 3);
        std::vector<float> refined(3 * std::size_t(cpu.refinedCount())), expected(refined.size()), actual(refined.size());
        cpu.evaluate(animate(t.loaded.mesh.positions, 3, 1), refined);
        cpu.normals(refined, expected);
        gpu.normals(refined, actual);
        expectClose(actual, expected, 1e-5, "normals");
    }
}

TEST_F(Vulkan, FlatGridNormalsPointUp) {
    const Tables t = tablesFor(test::dataPath("grid4x4.obj"), 3);
    VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, TableForm::Factorized);
    const std::vector<float> control(t.loaded.mesh.positions.begin(), t.loaded.mesh.positions.end());
    std::vector<float> refined(3 * std::size_t(gpu.refinedCount())), normals(refined.size());
    gpu.evaluate(control, refined, normals);
    for (std::size_t v = 0; v < normals.size() / 3; ++v) {
        EXPECT_FLOAT_EQ(normals[3 * v + 2], 1.0f) << v;
        EXPECT_FLOAT_EQ(normals[3 * v], 0.0f) << v;
    }
}

TEST_F(Vulkan, StagingCopiesGiveTheSameResults) {
    // The discrete-GPU paths run on whatever device is here: staging buffers and copies for
    // everything, and the control points written in place with the results staged (what a
    // discrete device with host-visible device memory gets).
    const Tables t = tablesFor(test::dataPath("cow.obj"), 2);
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized})
        for (Staging staging : {Staging::Always, Staging::Results}) {
            compareWithCpu(context(), t, form, 4, 2, {staging, 0});
            VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, form, 3, {staging, 0});
            EXPECT_EQ(gpu.controlsWrittenInPlace(), staging == Staging::Results);
        }
    // Staging::Always holds a staging buffer for the control points as well.
    VulkanEvaluator always(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 3, {Staging::Always, 0});
    VulkanEvaluator results(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 3, {Staging::Results, 0});
    EXPECT_GE(always.deviceBytes(), results.deviceBytes() + std::uint64_t(t.perLevel.controlCount) * 16);
}

TEST_F(Vulkan, SmallBindingLimitsSplitDispatchesAndBindWindowsWithTheSameResults) {
    // Bindings capped far below the device's limit: every table is split into chunks and the
    // vertex buffers are bound as several windows, on a mesh small enough to check quickly.
    const Tables t = tablesFor(test::dataPath("cow.obj"), 2);
    const std::uint64_t largest = std::uint64_t(t.perLevel.refinedCount()) * 4 * 4;  // width 4, floats
    const std::uint64_t cap = largest / 3 + 1024;                                  // three windows
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized})
        for (std::uint32_t width : {3u, 4u})
            for (Staging staging : {Staging::Auto, Staging::Always}) {
                SCOPED_TRACE("cap " + std::to_string(cap));
                compareWithCpu(context(), t, form, width, 2, {staging, cap});
                VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, form, width, {staging, cap});
                EXPECT_GT(gpu.dispatchCount(), form == TableForm::PerLevel ? t.perLevel.levels.size() : 1u);
            }
    // Tiny bindings: many chunks per level.
    const Tables small = tablesFor(test::dataPath("spot_control_mesh.obj"), 2);
    compareWithCpu(context(), small, TableForm::PerLevel, 3, 1, {Staging::Auto, 8192});
    compareWithCpu(context(), small, TableForm::Factorized, 3, 1, {Staging::Auto, 8192});
    VulkanEvaluator tiny(context(), small.perLevel, small.factorized, small.surface, TableForm::PerLevel, 3,
                         {Staging::Auto, 8192});
    EXPECT_GE(tiny.dispatchCount(true), 3 * small.perLevel.levels.size());
}

TEST_F(Vulkan, TablesAndVertexBuffersBeyond128MiBStillMatch) {
    // spot at 14 P-S steps: 6.0M refined vertices. The per-level table's indices (about
    // 300 MiB) exceed lavapipe's maxStorageBufferRange of 128 MiB, so its last levels are split
    // into chunks; at width 6 the refined vertex buffer (137 MiB) does too, so it is bound as
    // two windows.
    const auto start = std::chrono::steady_clock::now();
    const Tables t = tablesFor(test::dataPath("spot_control_mesh.obj"), 14, false);
    const std::uint32_t width = 6;
    ASSERT_GT(4 * t.perLevel.indices.size(), std::uint64_t(128) << 20);
    ASSERT_GT(std::uint64_t(t.perLevel.refinedCount()) * width * 4, std::uint64_t(128) << 20);
    CpuEvaluator<float> cpu(t.perLevel, t.factorized, t.surface, TableForm::PerLevel, width, 0);
    VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, width);
    EXPECT_GT(gpu.dispatchCount(), t.perLevel.levels.size());  // the last levels are split
    const std::vector<float> control = animate(t.loaded.mesh.positions, width, 1);
    std::vector<float> expected(std::size_t(cpu.refinedCount()) * width), actual(expected.size()),
        expectedNormals(3 * std::size_t(cpu.refinedCount())), actualNormals(expectedNormals.size());
    cpu.evaluate(control, expected);
    gpu.evaluate(control, actual, actualNormals);
    const double firstFrameMs = gpu.lastFrameTimes().totalMs;
    // Float on both sides, summed in another order (and with or without fused multiply-adds):
    // 2^-24 = 6e-8 of the size per rounding over 14 levels stays well inside 1e-5 of it.
    EXPECT_LE(maxDifference(actual, expected), 1e-5 * diagonal(t.loaded.mesh.positions));
    // Normals of faces this small are ill-conditioned in float: compare the normal passes on
    // the same positions.
    cpu.normals(expected, expectedNormals);
    gpu.normals(expected, actualNormals);
    EXPECT_LE(maxDifference(actualNormals, expectedNormals), 1e-5);  // unit vectors, float: as above
    gpu.evaluate(control, {});
    std::printf("spot, 14 steps, width %u: %u vertices, %.0f MiB on the device, %zu dispatches with normals, "
                "GPU frame %.0f ms (first, with normals), %.0f ms (stencils only); test %.1f s\n",
                width, gpu.refinedCount(), double(gpu.deviceBytes()) / 1048576, gpu.dispatchCount(true), firstFrameMs,
                gpu.lastFrameTimes().totalMs,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
}

TEST_F(Vulkan, FactorizedTableBeyond128MiBStillMatches) {
    // spot at 12 steps: 1.5M rows of about 40 entries, 240 MiB of indices (and as many of
    // weights): more than one binding of lavapipe's 128 MiB, so the rows are split.
    const Tables t = tablesFor(test::dataPath("spot_control_mesh.obj"), 12);
    ASSERT_GT(4 * t.factorized.indices.size(), std::uint64_t(128) << 20);
    CpuEvaluator<float> cpu(t.perLevel, t.factorized, t.surface, TableForm::Factorized, 3, 0);
    VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, TableForm::Factorized, 3);
    EXPECT_GT(gpu.dispatchCount(), 1u);
    const std::vector<float> control = animate(t.loaded.mesh.positions, 3, 2);
    std::vector<float> expected(3 * std::size_t(cpu.refinedCount())), actual(expected.size());
    cpu.evaluate(control, expected);
    gpu.evaluate(control, actual);
    EXPECT_LE(maxDifference(actual, expected), 1e-5 * diagonal(t.loaded.mesh.positions));  // float, as above
}

TEST_F(Vulkan, EmptyTablesAndZeroLevels) {
    {  // nothing at all
        const PerLevelTable perLevel;
        const FactorizedTable factorized;
        const SurfaceTable surface;
        for (TableForm form : {TableForm::PerLevel, TableForm::Factorized}) {
            VulkanEvaluator gpu(context(), perLevel, factorized, surface, form);
            EXPECT_EQ(gpu.refinedCount(), 0u);
            EXPECT_EQ(gpu.dispatchCount(true), 0u);
            gpu.evaluate({}, {});
        }
    }
    // A quad mesh refined 0 steps: the control points are the refined points.
    const Tables t = tablesFor(test::dataPath("cube.obj"), 0);
    ASSERT_TRUE(t.perLevel.levels.empty());
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized})
        for (Staging staging : {Staging::Auto, Staging::Always, Staging::Results}) {
            VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, form, 3, {staging, 0});
            const std::vector<float> control = animate(t.loaded.mesh.positions, 3, 0);
            std::vector<float> refined(control.size()), normals(control.size());
            gpu.evaluate(control, refined, normals);
            EXPECT_EQ(refined, control);
            CpuEvaluator<float> cpu(t.perLevel, t.factorized, t.surface, form, 3, 1);
            std::vector<float> expectedNormals(normals.size());
            cpu.normals(control, expectedNormals);
            expectClose(normals, expectedNormals, 1e-6, "cube normals");
        }
}

TEST_F(Vulkan, ADeviceThatIsNotThereIsAClearError) {
    struct RestoreEnv {
        std::optional<std::string> saved;
        RestoreEnv() {
            if (const char* v = std::getenv("PSUB_VULKAN_DEVICE")) saved = v;
        }
        ~RestoreEnv() {
            if (saved) ::setenv("PSUB_VULKAN_DEVICE", saved->c_str(), 1);
            else ::unsetenv("PSUB_VULKAN_DEVICE");
        }
    } restore;
    for (const char* selector : {"no-such-gpu-9000", "99"}) {
        ::setenv("PSUB_VULKAN_DEVICE", selector, 1);
        try {
            VulkanContext missing(VulkanOptions{Validation::Off, "", false, false});
            ADD_FAILURE() << "PSUB_VULKAN_DEVICE=" << selector << " found " << missing.deviceName();
        } catch (const VulkanError& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find(std::string("PSUB_VULKAN_DEVICE=\"") + selector + "\" matches no Vulkan device"),
                      std::string::npos) << message;
            EXPECT_NE(message.find("0: "), std::string::npos) << "lists the devices: " << message;
        }
    }
    ::unsetenv("PSUB_VULKAN_DEVICE");
    EXPECT_THROW(VulkanContext(VulkanOptions{Validation::Off, "not-a-device", false, false}), VulkanError);
    // The device that is here, by index and by name, is found.
    VulkanContext byIndex(VulkanOptions{Validation::Off, "0", false, false});
    const std::string name = byIndex.deviceName();
    VulkanContext byName(VulkanOptions{Validation::Off, name.substr(0, 4), false, false});
    EXPECT_FALSE(listVulkanDevices().empty());
}

// The window options (VulkanOptions): extra instance and device extensions are enabled, a
// missing one is named, and only queue families that pass the filter are chosen.
TEST_F(Vulkan, WindowOptionsEnableExtensionsAndFilterQueueFamilies) {
    VulkanOptions missing;
    missing.validation = Validation::Off;
    missing.instanceExtensions = {"VK_PSUB_no_such_extension"};
    try {
        VulkanContext made(missing);
        ADD_FAILURE() << "an unknown instance extension was accepted";
    } catch (const VulkanError& e) {
        EXPECT_NE(std::string(e.what()).find("VK_PSUB_no_such_extension"), std::string::npos) << e.what();
    }
    VulkanOptions noDeviceExtension;
    noDeviceExtension.validation = Validation::Off;
    noDeviceExtension.deviceExtensions = {"VK_PSUB_no_such_device_extension"};
    try {
        VulkanContext made(noDeviceExtension);
        ADD_FAILURE() << "a device without the asked extension was chosen";
    } catch (const VulkanError& e) {
        EXPECT_NE(std::string(e.what()).find("no VK_PSUB_no_such_device_extension"), std::string::npos) << e.what();
    }
    VulkanOptions none;
    none.validation = Validation::Off;
    none.queueFamilyFilter = [](void*, void*, std::uint32_t) { return false; };
    try {
        VulkanContext made(none);
        ADD_FAILURE() << "a queue family that fails the filter was chosen";
    } catch (const VulkanError& e) {
        EXPECT_NE(std::string(e.what()).find("no compute queue that can present"), std::string::npos) << e.what();
    }
    // The filter is asked with the context's own instance; the surface and swapchain
    // extensions are there on lavapipe and on every GPU driver.
    VulkanOptions window = validatedVulkanOptions();
    window.instanceExtensions = {"VK_KHR_surface"};
    window.deviceExtensions = {"VK_KHR_swapchain"};
    int calls = 0;
    void* instanceSeen = nullptr;
    window.queueFamilyFilter = [&](void* instance, void* physical, std::uint32_t) {
        instanceSeen = instance;
        ++calls;
        return physical != nullptr;
    };
    VulkanContext made(window);
    EXPECT_GT(calls, 0);
    EXPECT_EQ(instanceSeen, static_cast<void*>(contextInternals(made).instance));
    EXPECT_EQ(made.validationMessageCount(), 0u) << made.lastValidationMessage();
}

// Resident memory after glibc hands its free pages back (malloc_trim), so that the heap's
// reuse pattern is not mistaken for growth.
long residentKiB() {
    ::malloc_trim(0);
    std::ifstream statm("/proc/self/statm");
    long pages = 0, resident = 0;
    statm >> pages >> resident;
    return resident * (::sysconf(_SC_PAGESIZE) / 1024);
}

TEST_F(Vulkan, CreatingAndDestroyingEvaluatorsRepeatedlyLeaksNothing) {
    const Tables t = tablesFor(test::dataPath("cow.obj"), 2);
    const std::vector<float> control = animate(t.loaded.mesh.positions, 3, 0);
    std::vector<float> refined(3 * std::size_t(t.perLevel.refinedCount())), normals(refined.size());
    {
        // Its own context, destroyed at the end: the validation layer reports any object left
        // alive when the device is destroyed, and the process-wide count catches it.
        VulkanContext own(validatedVulkanOptions());
        long afterWarmUp = 0;
        for (int i = 0; i < 50; ++i) {
            if (i == 5) afterWarmUp = residentKiB();
            VulkanEvaluator gpu(own, t.perLevel, t.factorized, t.surface,
                                i % 2 ? TableForm::Factorized : TableForm::PerLevel, 3, {i % 3 ? Staging::Auto : Staging::Always, 0});
            gpu.evaluate(control, refined, normals);
        }
        // (Under AddressSanitizer freed memory is quarantined, and LeakSanitizer checks instead.)
        if (!kSanitized) {
            EXPECT_LT(residentKiB() - afterWarmUp, 4 * 1024) << "resident memory grew by KiB";
        }
    }
}

TEST_F(Vulkan, AValidationErrorIsCounted) {
    // The debug messenger really counts: a buffer of size 0 is invalid usage.
    VulkanContext::Impl& c = contextInternals(context());
    const std::uint64_t before = vulkanValidationMessageTotal();
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = 0;
    info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
    VkBuffer buffer = VK_NULL_HANDLE;
    ::testing::internal::CaptureStderr();
    const VkResult result = vkCreateBuffer(c.device, &info, nullptr, &buffer);
    const std::string printed = ::testing::internal::GetCapturedStderr();
    if (result == VK_SUCCESS && buffer) vkDestroyBuffer(c.device, buffer, nullptr);
    EXPECT_GT(vulkanValidationMessageTotal(), before);
    EXPECT_GT(context().validationMessageCount(), 0u);
    EXPECT_NE(printed.find("psub: Vulkan validation error"), std::string::npos) << printed;
    forgetMessages();
}

TEST_F(Vulkan, TimestampsGiveTheGpuTimeOfAFrame) {
    const Tables t = tablesFor(test::dataPath("cow.obj"), 2);
    VulkanEvaluator gpu(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel);
    const std::vector<float> control = animate(t.loaded.mesh.positions, 3, 0);
    std::vector<float> normals(3 * std::size_t(gpu.refinedCount()));
    gpu.evaluate(control, {}, normals);
    const GpuFrameTimes times = gpu.lastFrameTimes();
    ASSERT_TRUE(times.valid);
    EXPECT_GT(times.totalMs, 0);
    EXPECT_GT(times.levelsMs, 0);
    EXPECT_GT(times.normalsMs, 0);
    EXPECT_LE(times.levelsMs + times.normalsMs, times.totalMs * 1.0001);
}

TEST_F(Vulkan, InconsistentTablesAndWidthsAreRejected) {
    const Tables t = tablesFor(test::dataPath("cube.obj"), 2, false);
    EXPECT_THROW(VulkanEvaluator(context(), t.perLevel, t.factorized, t.surface, TableForm::Factorized),
                 std::invalid_argument);
    EXPECT_THROW(VulkanEvaluator(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 0),
                 std::invalid_argument);
    EXPECT_THROW(VulkanEvaluator(context(), t.perLevel, t.factorized, t.surface, TableForm::PerLevel, 17),
                 std::invalid_argument);
}

TEST(VulkanShaders, EmbeddedSpirvMatchesTheSharedConfig) {
    const vulkan::ShaderInfo info = vulkan::reflectSpirv(psub_spirv_level);
    EXPECT_EQ(info.localSize[0], unsigned(PSUB_WORKGROUP_SIZE));
    EXPECT_EQ(info.localSize[1], 1u);
    EXPECT_EQ(info.pushConstantBytes, sizeof(vulkan::PushConstants));
    // Every binding of the layout (some twice: float and vec4 views of one buffer), no other.
    std::vector<std::uint32_t> bindings = info.bindings;
    std::sort(bindings.begin(), bindings.end());
    bindings.erase(std::unique(bindings.begin(), bindings.end()), bindings.end());
    ASSERT_EQ(bindings.size(), std::size_t(PSUB_BINDING_COUNT));
    EXPECT_EQ(bindings.back(), std::uint32_t(PSUB_BINDING_COUNT - 1));
    const std::uint32_t garbage[6] = {1, 2, 3, 4, 5, 6};
    EXPECT_THROW(vulkan::reflectSpirv(garbage), VulkanError);
}

}  // namespace
}  // namespace psub
