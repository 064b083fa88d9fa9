// psub/image.h: pictures on the CPU: RGBA pixels, PNG files (libpng, written atomically),
// PNG and JPEG decoding (libpng and libjpeg-turbo, for textures),
// captions (stb_easy_font) and panels side by side. No Vulkan: the renderer (psub/render.h)
// and the analysis plots (psub/analysis.h) both draw into these. Link psub::image.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace psub {

struct Rgba {
    std::uint8_t r = 0, g = 0, b = 0, a = 255;
    bool operator==(const Rgba&) const = default;
};

// Pixels row by row from the top, 4 bytes (r, g, b, a) each.
struct Image {
    std::uint32_t width = 0, height = 0;
    std::vector<std::uint8_t> rgba;

    Rgba pixel(std::uint32_t x, std::uint32_t y) const;
    void setPixel(std::uint32_t x, std::uint32_t y, Rgba colour);
};

// An image of `width` x `height` filled with `colour`.
Image filledImage(std::uint32_t width, std::uint32_t height, Rgba colour);

// `image` as the bytes of an 8-bit RGBA PNG; std::runtime_error naming `path` on failure.
std::string encodePng(const std::string& path, const Image& image);

// Writes encodePng(path, image) with psub::writeOutput (atomic for a regular file; see
// psub/output.h); on failure no file is left and a std::runtime_error names `path`.
void writePng(const std::string& path, const Image& image);

// Reads an 8-bit RGB or RGBA PNG (for tests and tools); std::runtime_error naming `path`.
Image readPng(const std::string& path);

// The largest image decodeImage accepts: each side at most kMaxImageSide pixels and at most
// kMaxImagePixels pixels in all (256 MiB of RGBA).
inline constexpr std::uint32_t kMaxImageSide = 16384;
inline constexpr std::uint64_t kMaxImagePixels = 64ull * 1024 * 1024;

// A PNG (libpng) or JPEG (libjpeg-turbo) image decoded into 8-bit RGBA (grey, grey + alpha and
// RGB gain an opaque alpha; 16-bit PNG channels are reduced to 8 bits). `name` (the file, or "FILE.glb: image 0") starts every error message:
// std::runtime_error for bytes that are not a PNG or JPEG, are broken, or exceed the limits.
Image decodeImage(std::span<const std::uint8_t> bytes, const std::string& name);

// decodeImage of the bytes of the file at `path`; std::runtime_error naming `path` when it
// cannot be read.
Image readImage(const std::string& path);

// Draws `text` (ASCII, '\n' for new lines) with stb_easy_font: top-left corner at (x, y),
// `scale` pixels per font unit (a capital is 7 units tall). Clipped to the image.
void drawText(Image& image, int x, int y, const std::string& text, int scale, Rgba colour);
// Width and height in pixels of `text` drawn at `scale`.
std::array<int, 2> textSize(const std::string& text, int scale);

// A figure: `panels` (all the same size; std::invalid_argument otherwise) left to right, each
// with its caption centred in a band below it. captions.size() must equal panels.size().
Image panelsWithCaptions(std::span<const Image> panels, std::span<const std::string> captions,
                         int captionScale = 2, Rgba background = {255, 255, 255, 255},
                         Rgba textColour = {20, 20, 20, 255});

// Fills the rectangle with corners (x0, y0) and (x1, y1), both included, clipped to the image.
void fillRect(Image& image, int x0, int y0, int x1, int y1, Rgba colour);

}  // namespace psub
