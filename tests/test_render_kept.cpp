// Drawing straight from the Vulkan evaluator's device buffers (Renderer's evaluator
// constructor, drawKept): the same pictures as drawing host copies of the same results, with
// validation (synchronization included outside sanitizer builds) reporting nothing.
#include "psub/render.h"
#include "psub/stencils.h"
#include "psub/vulkan_evaluator.h"
#include "test_support.h"
#include "vulkan_test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace psub {
namespace {

// Mean absolute difference per channel value, in 1/255 steps.
double meanDifference(const Image& a, const Image& b) {
    double sum = 0;
    for (std::size_t i = 0; i < a.rgba.size(); ++i) sum += std::abs(double(a.rgba[i]) - double(b.rgba[i]));
    return a.rgba.empty() ? 0.0 : sum / double(a.rgba.size());
}

TEST(RenderKept, FramesFromDeviceBuffersEqualFramesFromHostCopies) {
    std::unique_ptr<VulkanContext> context;
    test::makeContextOrSkip(context);
    if (!context) return;
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
