// The Vulkan side of the tests' support: contexts with the Khronos validation layer on, made
// or refused the one way (a failure without a device, a skip only with PSUB_ALLOW_NO_VULKAN=1),
// and the fixture that gives each test its own validated context and fails it on any
// validation message. For test binaries that link psub_vulkan.
#pragma once

#include "psub/vulkan_evaluator.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>

namespace psub::test {

// Validation on; synchronization validation too, except under AddressSanitizer: Debian's layer
// (1.3.239) leaks with it (KhronosGroup/Vulkan-ValidationLayers#6033) and LeakSanitizer would
// fail the run.
inline VulkanOptions validatedVulkanOptions() {
    VulkanOptions options;
    options.validation = Validation::On;
    options.synchronizationValidation = !kSanitized;
    return options;
}

// Makes `context` with `options`; without a device it stays null and the test fails (skips with
// PSUB_ALLOW_NO_VULKAN=1): the caller returns when it is null.
inline void makeContextOrSkip(std::unique_ptr<VulkanContext>& context,
                              const VulkanOptions& options = validatedVulkanOptions()) {
    try {
        context = std::make_unique<VulkanContext>(options);
    } catch (const VulkanError& e) {
        if (noVulkanAllowed()) GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << e.what();
        FAIL() << "no Vulkan device: " << e.what() << " (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
    }
}

// Every test: its own validated context (or a failure; a skip only with
// PSUB_ALLOW_NO_VULKAN=1), no validation message while it runs, none when it is destroyed.
class ValidatedVulkanTest : public ::testing::Test {
protected:
    void SetUp() override {
        makeContextOrSkip(context_);
        if (!context_) return;
        ASSERT_TRUE(context_->validationEnabled());
        totalBefore_ = vulkanValidationMessageTotal();
    }
    void TearDown() override {
        if (!context_) return;
        EXPECT_EQ(context_->validationMessageCount(), 0u)
            << "validation messages; the last: " << context_->lastValidationMessage();
        context_.reset();
        EXPECT_EQ(vulkanValidationMessageTotal(), totalBefore_) << "validation messages on destruction (leaks?)";
    }
    VulkanContext& context() { return *context_; }

private:
    std::unique_ptr<VulkanContext> context_;
    std::uint64_t totalBefore_ = 0;
};

// A test of the psub program that needs a Vulkan device (a failure without one; a skip only
// with PSUB_ALLOW_NO_VULKAN=1): `dir_`, a fresh directory for its files, removed after it.
class VulkanCommandTest : public ::testing::Test {
protected:
    void SetUp() override {
        std::unique_ptr<VulkanContext> probe;
        makeContextOrSkip(probe, VulkanOptions{});
        if (!probe) return;
        ASSERT_FALSE(scratch_.path().empty());
        dir_ = scratch_.path();
    }
    ScratchDir scratch_;
    fs::path dir_;
};

}  // namespace psub::test
