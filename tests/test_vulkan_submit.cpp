// A validation message raised inside vkQueueSubmit is reported, not a deadlock: the debug
// messenger and queue submission take different locks. The submit runs on its own thread so
// that a hang fails the test (and ends the process) instead of stalling the suite.
#include "psub/vulkan_evaluator.h"
#include "test_support.h"
#include "vulkan_test_support.h"

// Internal headers: the context's handles and the submit helper under test.
#include "device.h"
#include "resources.h"
#include "submit.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <memory>
#include <string>

namespace psub {
namespace {

// An empty, recorded command buffer and a fence created already signaled: submitting with a
// signaled fence breaks VUID-vkQueueSubmit-fence-00063, which the layer reports from inside
// vkQueueSubmit; drivers simply signal the fence again, so nothing else is harmed.
struct SignaledFenceSubmit {
    VulkanContext::Impl& c;
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer command = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;

    explicit SignaledFenceSubmit(VulkanContext::Impl& context) : c(context) {
        VkCommandPoolCreateInfo poolInfo{};
        poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        poolInfo.queueFamilyIndex = c.queueFamily;
        VK_CHECK(vkCreateCommandPool(c.device, &poolInfo, nullptr, &pool));
        VkCommandBufferAllocateInfo allocate{};
        allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        allocate.commandPool = pool;
        allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        allocate.commandBufferCount = 1;
        VK_CHECK(vkAllocateCommandBuffers(c.device, &allocate, &command));
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        VK_CHECK(vkBeginCommandBuffer(command, &begin));
        VK_CHECK(vkEndCommandBuffer(command));
        VkFenceCreateInfo fenceInfo{};
        fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        fenceInfo.flags = VK_FENCE_CREATE_SIGNALED_BIT;
        VK_CHECK(vkCreateFence(c.device, &fenceInfo, nullptr, &fence));
    }
    ~SignaledFenceSubmit() {
        vkDeviceWaitIdle(c.device);
        vkDestroyFence(c.device, fence, nullptr);
        vkDestroyCommandPool(c.device, pool, nullptr);
    }
};

TEST(VulkanSubmit, AValidationMessageDuringASubmitIsReportedNotADeadlock) {
    VulkanOptions options;
    options.validation = Validation::On;
    std::unique_ptr<VulkanContext> context;
    test::makeContextOrSkip(context, options);
    if (!context) return;
    ASSERT_TRUE(context->validationEnabled());
    SignaledFenceSubmit bad(contextInternals(*context));
    const std::uint64_t before = context->validationMessageCount();

    ::testing::internal::CaptureStderr();
    std::future<void> submitted = std::async(std::launch::async, [&] {
        vulkan::submitAndWait(contextInternals(*context), bad.command, bad.fence);
    });
    if (submitted.wait_for(std::chrono::seconds(60)) != std::future_status::ready) {
        // The submitting thread is stuck holding a lock: nothing can be cleaned up. (stderr is
        // being captured, so the verdict goes to stdout.)
        std::printf("FAILED: the submit with a validation message did not return in 60 s\n");
        std::fflush(stdout);
        std::_Exit(1);
    }
    submitted.get();
    const std::string printed = ::testing::internal::GetCapturedStderr();

    EXPECT_GT(context->validationMessageCount(), before);
    EXPECT_NE(context->lastValidationMessage().find("VUID-vkQueueSubmit-fence-00063"), std::string::npos)
        << context->lastValidationMessage();
    EXPECT_NE(printed.find("psub: Vulkan validation error"), std::string::npos) << printed;
}

}  // namespace
}  // namespace psub
