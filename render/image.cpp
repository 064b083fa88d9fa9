// Images on the CPU: pixels, PNG files (libpng's simplified API; written by psub::output),
// captions drawn from stb_easy_font's quads, and panels side by side with captions.
#include "psub/image.h"
#include "psub/output.h"

#include <png.h>
#include <stb_easy_font.h>

#include <algorithm>
#include <cassert>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>


namespace psub {
namespace {

std::size_t offsetOf(const Image& image, std::uint32_t x, std::uint32_t y) {
    return 4 * (std::size_t(y) * image.width + x);
}

[[noreturn]] void failWrite(const std::string& path, const std::string& why) {
    throw std::runtime_error(path + ": cannot write: " + why);
}

}  // namespace

std::string encodePng(const std::string& path, const Image& image) {
    if (image.rgba.size() != 4 * std::size_t(image.width) * image.height || image.width == 0 || image.height == 0)
        throw std::invalid_argument(path + ": the image's pixels do not match its size " +
                                    std::to_string(image.width) + "x" + std::to_string(image.height));
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    png.width = image.width;
    png.height = image.height;
    png.format = PNG_FORMAT_RGBA;
    png_alloc_size_t size = 0;
    if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.rgba.data(), 0, nullptr))
        failWrite(path, std::string("libpng: ") + png.message);
    std::string bytes(size, '\0');
    if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, image.rgba.data(), 0, nullptr))
        failWrite(path, std::string("libpng: ") + png.message);
    bytes.resize(size);
    return bytes;
}

Rgba Image::pixel(std::uint32_t x, std::uint32_t y) const {
    assert(x < width && y < height);
    const std::uint8_t* p = &rgba[offsetOf(*this, x, y)];
    return {p[0], p[1], p[2], p[3]};
}

void Image::setPixel(std::uint32_t x, std::uint32_t y, Rgba c) {
    assert(x < width && y < height);
    std::uint8_t* p = &rgba[offsetOf(*this, x, y)];
    p[0] = c.r, p[1] = c.g, p[2] = c.b, p[3] = c.a;
}

Image filledImage(std::uint32_t width, std::uint32_t height, Rgba colour) {
    Image image{width, height, std::vector<std::uint8_t>(4 * std::size_t(width) * height)};
    for (std::size_t i = 0; i < image.rgba.size(); i += 4)
        image.rgba[i] = colour.r, image.rgba[i + 1] = colour.g, image.rgba[i + 2] = colour.b, image.rgba[i + 3] = colour.a;
    return image;
}

void writePng(const std::string& path, const Image& image) {
    writeOutput(path, encodePng(path, image));
}

void fillRect(Image& image, int x0, int y0, int x1, int y1, Rgba colour) {
    const int left = std::max(0, std::min(x0, x1)), right = std::min(int(image.width) - 1, std::max(x0, x1));
    const int top = std::max(0, std::min(y0, y1)), bottom = std::min(int(image.height) - 1, std::max(y0, y1));
    for (int y = top; y <= bottom; ++y)
        for (int x = left; x <= right; ++x) image.setPixel(std::uint32_t(x), std::uint32_t(y), colour);
}

Image readPng(const std::string& path) {
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&png, path.c_str()))
        throw std::runtime_error(path + ": cannot read PNG: " + png.message);
    png.format = PNG_FORMAT_RGBA;
    Image image{png.width, png.height, std::vector<std::uint8_t>(PNG_IMAGE_SIZE(png))};
    if (!png_image_finish_read(&png, nullptr, image.rgba.data(), 0, nullptr))
        throw std::runtime_error(path + ": cannot read PNG: " + png.message);
    return image;
}

std::array<int, 2> textSize(const std::string& text, int scale) {
    std::string copy = text;
    return {stb_easy_font_width(copy.data()) * scale, stb_easy_font_height(copy.data()) * scale};
}

void drawText(Image& image, int x, int y, const std::string& text, int scale, Rgba colour) {
    struct Vertex {
        float x, y, z;
        unsigned char colour[4];
    };
    static_assert(sizeof(Vertex) == 16);
    std::string copy = text;
    std::vector<Vertex> vertices(4 * 80 * (text.size() + 1));  // at most ~70 segments a glyph
    const int quads = stb_easy_font_print(0, 0, copy.data(), nullptr, vertices.data(),
                                          int(vertices.size() * sizeof(Vertex)));
    const int width = int(image.width), height = int(image.height);
    for (int q = 0; q < quads; ++q) {
        const Vertex* v = &vertices[4 * std::size_t(q)];
        const float x0 = std::min(v[0].x, v[2].x), x1 = std::max(v[0].x, v[2].x);
        const float y0 = std::min(v[0].y, v[2].y), y1 = std::max(v[0].y, v[2].y);
        const int left = std::max(0, x + int(x0) * scale), right = std::min(width, x + int(x1) * scale);
        const int top = std::max(0, y + int(y0) * scale), bottom = std::min(height, y + int(y1) * scale);
        for (int py = top; py < bottom; ++py)
            for (int px = left; px < right; ++px) image.setPixel(std::uint32_t(px), std::uint32_t(py), colour);
    }
}

Image panelsWithCaptions(std::span<const Image> panels, std::span<const std::string> captions, int captionScale,
                         Rgba background, Rgba textColour) {
    if (panels.empty() || captions.size() != panels.size())
        throw std::invalid_argument("panelsWithCaptions: one caption per panel, at least one panel");
    const std::uint32_t w = panels[0].width, h = panels[0].height;
    for (const Image& p : panels)
        if (p.width != w || p.height != h || p.rgba.size() != 4 * std::size_t(w) * h)
            throw std::invalid_argument("panelsWithCaptions: panels differ in size");
    int textHeight = 0;
    for (const std::string& c : captions) textHeight = std::max(textHeight, textSize(c, captionScale)[1]);
    const int pad = 4 * captionScale;
    const std::uint32_t band = std::uint32_t(textHeight + 2 * pad);
    Image figure = filledImage(w * std::uint32_t(panels.size()), h + band, background);
    for (std::size_t i = 0; i < panels.size(); ++i) {
        for (std::uint32_t y = 0; y < h; ++y)
            std::memcpy(&figure.rgba[offsetOf(figure, std::uint32_t(i) * w, y)], &panels[i].rgba[offsetOf(panels[i], 0, y)],
                        4 * std::size_t(w));
        const int left = int(i * w) + std::max(0, (int(w) - textSize(captions[i], captionScale)[0]) / 2);
        drawText(figure, left, int(h) + pad, captions[i], captionScale, textColour);
    }
    return figure;
}

}  // namespace psub
