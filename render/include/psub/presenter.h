// psub/presenter.h: shows psub/image.h pictures in a GLFW window through a Vulkan surface and
// swapchain (psub view). The pictures are drawn elsewhere (psub::Renderer, captions); this only
// copies each one into the acquired swapchain image and presents it, two frames in flight.
// Link psub::present. No Vulkan types here.
#pragma once

#include "psub/image.h"
#include "psub/vulkan_evaluator.h"

#include <array>
#include <cstdint>
#include <memory>

struct GLFWwindow;

namespace psub {

// What a VulkanContext needs to present to GLFW windows: GLFW's instance extensions,
// VK_KHR_swapchain, and only queue families that can present. Call after glfwInit().
VulkanOptions presentableOptions(VulkanOptions base = {});

// Colour space, the same on both sides: the renderer's pixels are 8-bit values meant as sRGB
// (as written to PNG files); the swapchain uses a UNORM format (B8G8R8A8 or R8G8B8A8) in
// VK_COLOR_SPACE_SRGB_NONLINEAR_KHR, so the bytes reach the display unchanged (no sRGB
// encoding on the way), and a screenshot reads back the very bytes that were shown.
class Presenter {
public:
    // A swapchain for `window` on `context` (created with presentableOptions). vsync: FIFO;
    // otherwise IMMEDIATE or MAILBOX when the surface has one. Throws VulkanError.
    Presenter(VulkanContext& context, GLFWwindow* window, bool vsync);
    ~Presenter();
    Presenter(const Presenter&) = delete;
    Presenter& operator=(const Presenter&) = delete;

    // The swapchain's size in pixels (width, height).
    std::array<std::uint32_t, 2> extent() const;

    // Re-creates the swapchain at the window's current size (after a resize). Waits for the
    // frames in flight first.
    void recreate();

    // Copies `image` into the next swapchain image (the overlap when sizes differ, the rest
    // cleared to `background`) and presents it; with `capture`, the swapchain image is also
    // copied back for screenshot(). Returns false when the swapchain was out of date or
    // suboptimal (it is re-created; draw again at extent()).
    bool present(const Image& image, bool capture = false, Rgba background = {255, 255, 255, 255});

    // The swapchain image of the last present() with capture, as RGBA (waits for it).
    Image screenshot();

    // The present mode in words ("fifo", "immediate", "mailbox").
    const char* presentMode() const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace psub
