// Drawing straight from the Vulkan evaluator's device buffers (Renderer's evaluator
// constructor, drawKept): the same pictures as drawing host copies of the same results, with
// validation (synchronization included outside sanitizer builds) reporting nothing.
#include "psub/render.h"
#include "psub/stencils.h"
#include "psub/vulkan_evaluator.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace psub {
namespace {

bool noVulkanAllowed() {
    const char* allow = std::getenv("PSUB_ALLOW_NO_VULKAN");
    return allow && std::string(allow) == "1";
}

// Mean absolute difference per channel value, in 1/255 steps.
double meanDifference(const Image& a, const Image& b) {
    double sum = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i) sum += std::abs(double(a.rgba[i]) - double(b.rgba[i]));
    return a.rgba.empty() ? 0.0 : sum / double(a.rgba.size());
}

TEST(RenderKept, FramesFromDeviceBuffersEqualFramesFromHostCopies) {
    std::unique_ptr<VulkanContext> context;
    try {
        VulkanOptions options;
        options.validation = Validation::On;
        options.synchronizationValidation = !test::kSanitized;  // see test_render.cpp: the layer leaks with it
        context = std::make_unique<VulkanContext>(options);
    } catch (const VulkanError& e) {
        if (noVulkanAllowed()) GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << e.what();
        FAIL() << "no Vulkan device: " << e.what() << " (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
    }
    const test::Loaded loaded = test::load(test::dataPath("spot_control_mesh.obj"));
    RefineOptions refineOptions;
    refineOptions.levels = 2;
    const Refinement r = refine(loaded.mesh, loaded.checked.connectivity, refineOptions);
    VulkanEvaluator gpu(*context, r.perLevel, r.factorized, r.surface, TableForm::PerLevel);
    RenderOptions options;
    options.width = 160, options.height = 120, options.wireframe = Wireframe::Refined;
    Renderer host(*context, polygonsOf(gpu.surface()), options);
    Renderer kept(*context, gpu, options);
    EXPECT_EQ(kept.triangleCount(), host.triangleCount());
    EXPECT_THROW(host.drawKept(Camera{}, *std::make_unique<Image>()), std::logic_error);

    std::vector<float> control, positions(3 * std::size_t(gpu.refinedCount())), normals(positions.size());
    for (double x : loaded.mesh.positions) control.push_back(float(x));
    Box box;
    box.extend(control);
    const Camera camera = frameBox(box, 160.0f / 120.0f);
    Image fromHost, fromDevice, previous;
    for (int frame = 0; frame < 3; ++frame) {  // frames differ: the device picture follows them
        for (std::size_t i = 1; i < control.size(); i += 3)
            control[i] = float(loaded.mesh.positions[i] + 0.05 * std::sin(double(i) + frame));
        gpu.evaluate(control, positions, normals);
        host.draw(positions, normals, camera, fromHost);
        gpu.evaluateKept(control, true);
        kept.drawKept(camera, fromDevice);
        EXPECT_LE(meanDifference(fromHost, fromDevice), 1.0) << "frame " << frame;  // within 1/255 on average
        if (frame > 0) {
            EXPECT_GT(meanDifference(previous, fromDevice), 0.0) << "frame " << frame;
        }
        previous = fromDevice;
    }
    Image background = filledImage(160, 120, options.background);
    EXPECT_GT(meanDifference(background, fromDevice), 1.0);  // the surface is drawn at all
    EXPECT_EQ(context->validationMessageCount(), 0u) << context->lastValidationMessage();
}

}  // namespace
}  // namespace psub
