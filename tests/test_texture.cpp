// Textured rendering: PNG and JPEG decoding (libpng, libjpeg-turbo) and its errors; the CPU mip levels;
// the renderer's texture path on hand-made per-corner UVs (a 2x2 checker seen head-on, two UV
// islands meeting at a seam, minification through the mip chain, the factor against the flat
// colour, bad UVs refused); `psub render --texture` errors. Every renderer test runs with the
// validation layer on and fails on any message, and without a device unless
// PSUB_ALLOW_NO_VULKAN=1.
#include "psub/image.h"
#include "psub/render.h"
#include "psub/vulkan_evaluator.h"
#include "test_support.h"
#include "vulkan_test_support.h"
#include "texture.h"

#include <gtest/gtest.h>

#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

namespace psub {
namespace {

namespace fs = std::filesystem;


std::vector<std::uint8_t> bytesOf(const std::string& s) { return {s.begin(), s.end()}; }

void appendBytes(void* context, void* data, int size) {
    auto* out = static_cast<std::vector<std::uint8_t>*>(context);
    const auto* bytes = static_cast<const std::uint8_t*>(data);
    for (int i = 0; i < size; ++i) out->push_back(bytes[i]);
}

// A baseline JPEG of `image` (stb_image_write); empty if the writer fails.
std::vector<std::uint8_t> encodeJpeg(const Image& image, int quality) {
    std::vector<std::uint8_t> jpeg;
    if (!stbi_write_jpg_to_func(appendBytes, &jpeg, int(image.width), int(image.height), 4, image.rgba.data(), quality))
        jpeg.clear();
    return jpeg;
}

std::string errorOf(const std::vector<std::uint8_t>& bytes, const std::string& name) {
    try {
        decodeImage(bytes, name);
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "";
}

// A `width` x `height` image whose pixel (x, y) is colour(x, y).
template <class Colour>
Image makeImage(std::uint32_t width, std::uint32_t height, Colour colour) {
    Image image = filledImage(width, height, {});
    for (std::uint32_t y = 0; y < height; ++y)
        for (std::uint32_t x = 0; x < width; ++x) image.setPixel(x, y, colour(x, y));
    return image;
}

// ---------------------------------------------------------------------------------------
// Decoding

TEST(ImageDecode, PngRoundTripsExactly) {
    const Image image = makeImage(5, 3, [](std::uint32_t x, std::uint32_t y) {
        return Rgba{std::uint8_t(40 * x), std::uint8_t(70 * y), 200, std::uint8_t(255 - 10 * x)};
    });
    const Image decoded = decodeImage(bytesOf(encodePng("t.png", image)), "t.png");
    EXPECT_EQ(decoded.width, 5u);
    EXPECT_EQ(decoded.height, 3u);
    EXPECT_EQ(decoded.rgba, image.rgba);
}

TEST(ImageDecode, JpegDecodesToOpaqueRgba) {
    // Left half red, right half blue, 32x16 at quality 100 (stb_image_write, baseline JPEG).
    const Image image = makeImage(32, 16, [](std::uint32_t x, std::uint32_t) {
        return x < 16 ? Rgba{220, 20, 20, 255} : Rgba{20, 20, 220, 255};
    });
    const std::vector<std::uint8_t> jpeg = encodeJpeg(image, 100);
    ASSERT_FALSE(jpeg.empty());
    const Image decoded = decodeImage(jpeg, "t.jpg");
    ASSERT_EQ(decoded.width, 32u);
    ASSERT_EQ(decoded.height, 16u);
    for (std::uint32_t y = 0; y < 16; ++y)
        for (std::uint32_t x : {2u, 5u, 26u, 29u}) {
            const Rgba want = image.pixel(x, y), got = decoded.pixel(x, y);
            // Bound 12 of 255 (under 5%): room for JPEG's loss at quality 100 (colour conversion,
            // quantisation); red and blue stay 200 levels apart.
            EXPECT_NEAR(got.r, want.r, 12) << x << "," << y;
            EXPECT_NEAR(got.g, want.g, 12) << x << "," << y;
            EXPECT_NEAR(got.b, want.b, 12) << x << "," << y;
            EXPECT_EQ(got.a, 255);
        }
}

TEST(ImageDecode, BrokenImagesNameTheFile) {
    const std::string png = encodePng("t.png", filledImage(8, 8, {1, 2, 3, 255}));
    EXPECT_NE(errorOf({}, "empty.png").find("empty.png: cannot decode the image: the file is empty"), std::string::npos);
    EXPECT_NE(errorOf(bytesOf("not an image at all"), "text.png").find("text.png: cannot decode"), std::string::npos);
    EXPECT_NE(errorOf(bytesOf(png.substr(0, png.size() / 2)), "cut.png").find("cut.png: cannot decode"),
              std::string::npos);
    EXPECT_NE(errorOf(bytesOf("GIF89a\x01\x00\x01\x00\x00\x00\x00"), "a.gif").find("a.gif: cannot decode"),
              std::string::npos);
    // The header claims 20000 pixels across: refused before any pixel is decoded.
    std::string wide = png;
    wide[16] = 0, wide[17] = 0, wide[18] = char(0x4e), wide[19] = char(0x20);
    EXPECT_NE(errorOf(bytesOf(wide), "wide.png").find("wide.png: cannot decode"), std::string::npos);
}

// A JPEG whose Huffman table (DHT segment) counts 16 x 17 = 272 codes, more than the 256 a table
// can hold. stb_image (the decoder before libjpeg-turbo) wrote past its 257-entry size list on
// this; found by fuzz_image once the libraries were built with coverage instrumentation.
TEST(ImageDecode, AnOverfullJpegHuffmanTableIsRefused) {
    // SOI; DHT of 0x123 bytes, table 0; the code counts per length (272 in all); the symbols
    // (2 + 1 + 16 + 272 = 0x123 bytes with the length field); EOI.
    std::vector<std::uint8_t> jpeg(7 + 16 + 272 + 2, 0);
    const std::uint8_t head[7] = {0xFF, 0xD8, 0xFF, 0xC4, 0x01, 0x23, 0x00};
    std::copy(std::begin(head), std::end(head), jpeg.begin());
    std::fill(jpeg.begin() + 7, jpeg.begin() + 7 + 16, std::uint8_t(17));
    jpeg[jpeg.size() - 2] = 0xFF, jpeg[jpeg.size() - 1] = 0xD9;
    EXPECT_NE(errorOf(jpeg, "huffman.jpg").find("huffman.jpg: cannot decode the image: JPEG: "), std::string::npos)
        << errorOf(jpeg, "huffman.jpg");
}

TEST(ImageDecode, BrokenJpegsNameTheFile) {
    const Image image = filledImage(32, 16, {200, 30, 40, 255});
    const std::vector<std::uint8_t> jpeg = encodeJpeg(image, 90);
    ASSERT_FALSE(jpeg.empty());
    // Cut in half: libjpeg would fill the rest with grey and warn; a warning is an error here.
    const std::vector<std::uint8_t> cut(jpeg.begin(), jpeg.begin() + std::ptrdiff_t(jpeg.size() / 2));
    EXPECT_NE(errorOf(cut, "cut.jpg").find("cut.jpg: cannot decode the image: JPEG: "), std::string::npos)
        << errorOf(cut, "cut.jpg");
    // The start-of-frame header (FF C0, then length, precision, height, width) claims 20000 rows.
    std::vector<std::uint8_t> tall = jpeg;
    for (std::size_t i = 0; i + 8 < tall.size(); ++i)
        if (tall[i] == 0xFF && tall[i + 1] == 0xC0) {
            tall[i + 5] = 0x4e, tall[i + 6] = 0x20;
            break;
        }
    EXPECT_NE(errorOf(tall, "tall.jpg").find("tall.jpg: cannot decode the image: 32x20000 pixels is beyond the limit"),
              std::string::npos)
        << errorOf(tall, "tall.jpg");
}

TEST(ImageDecode, ReadImageNamesAMissingFile) {
    const std::string path = (fs::temp_directory_path() / "psub_no_such_texture.png").string();
    try {
        readImage(path);
        FAIL() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(path + ": cannot open the image"), std::string::npos) << e.what();
    }
}

TEST(ImageDecode, ReadImageReadsAFile) {
    const fs::path path = fs::temp_directory_path() / ("psub_texture_" + std::to_string(::getpid()) + ".png");
    const Image image = filledImage(3, 4, {9, 8, 7, 255});
    writePng(path.string(), image);
    EXPECT_EQ(readImage(path.string()).rgba, image.rgba);
    fs::remove(path);
}

// The CPU's mip levels (used where the device cannot blit the texture's format).
TEST(TextureMips, LevelCountAndBoxFilter) {
    EXPECT_EQ(render_detail::mipLevelCount(1, 1), 1u);
    // floor(log2(the larger side)) + 1: 256 -> 8 + 1, 300 -> 8 + 1.
    EXPECT_EQ(render_detail::mipLevelCount(2, 1), 2u);
    EXPECT_EQ(render_detail::mipLevelCount(256, 3), 9u);
    EXPECT_EQ(render_detail::mipLevelCount(5, 300), 9u);
    const Image checker = makeImage(4, 2, [](std::uint32_t x, std::uint32_t y) {
        return (x + y) % 2 ? Rgba{255, 255, 255, 255} : Rgba{0, 0, 0, 255};
    });
    const Image half = render_detail::halveImage(checker);
    ASSERT_EQ(half.width, 2u);
    ASSERT_EQ(half.height, 1u);
    // Each 2 x 2 box holds two black and two white texels: (0 + 255 + 255 + 0) / 4 = 127.5, rounded
    // up; the column's (0 + 100) / 2 = 50.
    EXPECT_EQ(half.pixel(0, 0), (Rgba{128, 128, 128, 255}));
    EXPECT_EQ(half.pixel(1, 0), (Rgba{128, 128, 128, 255}));
    const Image column = render_detail::halveImage(makeImage(1, 2, [](std::uint32_t, std::uint32_t y) {
        return Rgba{std::uint8_t(100 * y), 0, 0, 255};
    }));
    EXPECT_EQ(column.width, 1u);
    EXPECT_EQ(column.height, 1u);
    EXPECT_EQ(column.pixel(0, 0), (Rgba{50, 0, 0, 255}));
}

// ---------------------------------------------------------------------------------------
// The renderer's texture path

using test::kSanitized;

// Every test: its own validated context, no validation message (vulkan_test_support.h).
class Textured : public test::ValidatedVulkanTest {};

// A flat surface in the plane z = 0 facing +z: vertices, faces, normals.
struct Flat {
    std::vector<float> positions, normals;
    std::vector<std::uint32_t> offsets, verts;
    Polygons polygons() const { return {std::uint32_t(positions.size() / 3), offsets, verts}; }
};

// The square [-1, 1]^2 as one quad.
Flat square() {
    Flat f;
    f.positions = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
    f.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    f.offsets = {0, 4};
    f.verts = {0, 1, 2, 3};
    return f;
}

// The pixel (x, y) where the world point `p` lands (psub/render.h's convention).
std::array<std::uint32_t, 2> pixelOf(const Camera& camera, std::array<float, 3> p, std::uint32_t width,
                                     std::uint32_t height) {
    const auto& m = camera.viewProjection;
    float clip[4];
    for (int r = 0; r < 4; ++r) clip[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
    const float x = (clip[0] / clip[3] + 1) / 2 * float(width), y = (clip[1] / clip[3] + 1) / 2 * float(height);
    return {std::uint32_t(x), std::uint32_t(y)};
}

// Head-on: the camera on +z looking at the square [-1, 1]^2 (framed with a margin).
Camera headOn(float aspect = 1) { return frameBox({-1, -1, 0}, {1, 1, 0}, aspect, {0, 0, 1}); }

Rgba at(const Image& image, const Camera& camera, float x, float y) {
    const auto p = pixelOf(camera, {x, y, 0}, image.width, image.height);
    return image.pixel(p[0], p[1]);
}

RenderOptions small(std::uint32_t side = 128) {
    RenderOptions o;
    o.width = o.height = side;
    o.samples = 1;
    return o;
}

const Rgba kRed{255, 0, 0, 255}, kGreen{0, 255, 0, 255}, kBlue{0, 0, 255, 255}, kWhite{255, 255, 255, 255};

// Lit colours keep the texture's hue: each channel that is 0 in the texel stays near 0, each
// that is 255 stays bright.
void expectHue(Rgba got, Rgba texel, const std::string& where) {
    for (auto [g, t] : {std::pair{got.r, texel.r}, std::pair{got.g, texel.g}, std::pair{got.b, texel.b}}) {
        if (t == 0) {
            EXPECT_LT(g, 8) << where;
        }
        if (t == 255) {
            EXPECT_GT(g, 200) << where;
        }
    }
}

TEST_F(Textured, CheckerQuadrantsHeadOn) {
    // 2x2 texels: top row red, green; bottom row blue, white. glTF UVs: v = 0 at the top, so
    // the square's top-left corner (-1, 1) takes uv (0, 0).
    const Image checker = makeImage(2, 2, [](std::uint32_t x, std::uint32_t y) {
        return y == 0 ? (x == 0 ? kRed : kGreen) : (x == 0 ? kBlue : kWhite);
    });
    const Flat s = square();
    const std::vector<std::uint32_t> values = {0, 1, 2, 3};
    const std::vector<float> uv = {0, 1, 1, 1, 1, 0, 0, 0};
    SurfaceTexture texture{s.offsets, s.verts, values, uv, &checker};
    Renderer renderer(context(), s.polygons(), small(), {}, texture);
    const Camera camera = headOn();
    Image out;
    renderer.draw(s.positions, s.normals, camera, out);
    EXPECT_EQ(renderer.triangleCount(), 2u);
    // Quadrant centres sample texel centres exactly.
    expectHue(at(out, camera, -0.5f, 0.5f), kRed, "top left");
    expectHue(at(out, camera, 0.5f, 0.5f), kGreen, "top right");
    expectHue(at(out, camera, -0.5f, -0.5f), kBlue, "bottom left");
    expectHue(at(out, camera, 0.5f, -0.5f), kWhite, "bottom right");
    // Outside the square: the background.
    EXPECT_EQ(out.pixel(1, 1), (Rgba{255, 255, 255, 255}));
}

// Two quads share the edge x = 0 (vertices 1 and 4) but not its UVs: the left quad maps to
// the texture's right (green) half, the right quad to its left (red) half. Per-vertex UVs
// could not do this; per corner, each side samples its own island up to the seam.
TEST_F(Textured, EachSideOfASeamSamplesItsOwnIsland) {
    Flat f;
    f.positions = {-1, -1, 0, 0, -1, 0, 1, -1, 0, -1, 1, 0, 0, 1, 0, 1, 1, 0};
    f.normals.assign(18, 0);
    for (std::size_t v = 0; v < 6; ++v) f.normals[3 * v + 2] = 1;
    f.offsets = {0, 4, 8};
    f.verts = {0, 1, 4, 3, 1, 2, 5, 4};
    const std::vector<std::uint32_t> values = {0, 1, 2, 3, 4, 5, 6, 7};
    const std::vector<float> uv = {0.6f, 0.9f, 0.9f, 0.9f, 0.9f, 0.1f, 0.6f, 0.1f,   // left quad: green island
                                   0.1f, 0.9f, 0.4f, 0.9f, 0.4f, 0.1f, 0.1f, 0.1f};  // right quad: red island
    const Image halves = makeImage(64, 64, [](std::uint32_t x, std::uint32_t) { return x < 32 ? kRed : kGreen; });
    SurfaceTexture texture{f.offsets, f.verts, values, uv, &halves};
    const RenderOptions o = small(160);
    Renderer renderer(context(), f.polygons(), o, {}, texture);
    const Camera camera = headOn();
    Image out;
    renderer.draw(f.positions, f.normals, camera, out);
    for (float y : {-0.8f, -0.3f, 0.2f, 0.7f}) {
        for (float x : {-0.9f, -0.5f, -0.1f}) expectHue(at(out, camera, x, y), kGreen, "left of the seam");
        for (float x : {0.1f, 0.5f, 0.9f}) expectHue(at(out, camera, x, y), kRed, "right of the seam");
        // The change is at the seam itself: the pixels next to it on either side.
        const auto seam = pixelOf(camera, {0, y, 0}, o.width, o.height);
        expectHue(out.pixel(seam[0] - 2, seam[1]), kGreen, "two pixels left of the seam");
        expectHue(out.pixel(seam[0] + 2, seam[1]), kRed, "two pixels right of the seam");
    }
}

// A one-pixel checker of 256x256 texels drawn across about 40 pixels: through the mip chain
// every pixel is the checker's mean (half the lit white), not black or white texels.
TEST_F(Textured, MinifiedCheckerAveragesToGrey) {
    const Image fine = makeImage(256, 256, [](std::uint32_t x, std::uint32_t y) { return (x + y) % 2 ? kWhite : Rgba{0, 0, 0, 255}; });
    const Image white = filledImage(1, 1, kWhite);
    const Flat s = square();
    const std::vector<std::uint32_t> values = {0, 1, 2, 3};
    const std::vector<float> uv = {0, 1, 1, 1, 1, 0, 0, 0};
    const Camera camera = headOn();
    Image grey, lit;
    Renderer(context(), s.polygons(), small(64), {}, SurfaceTexture{s.offsets, s.verts, values, uv, &fine})
        .draw(s.positions, s.normals, camera, grey);
    Renderer(context(), s.polygons(), small(64), {}, SurfaceTexture{s.offsets, s.verts, values, uv, &white})
        .draw(s.positions, s.normals, camera, lit);
    int checked = 0;
    for (float y = -0.8f; y <= 0.8f; y += 0.1f)
        for (float x = -0.8f; x <= 0.8f; x += 0.1f) {
            const Rgba g = at(grey, camera, x, y), w = at(lit, camera, x, y);
            // The checker's mean is half the white; tolerance 0.06: 8-bit rounding of both
            // pixels and filtering at the mip levels' edges.
            EXPECT_NEAR(double(g.r) / double(w.r), 0.5, 0.06) << x << "," << y;
            EXPECT_EQ(g.r, g.g);
            ++checked;
        }
    EXPECT_GT(checked, 200);  // 17 x 17 = 289 points, 16 x 16 = 256 if float steps miss 0.8
}

// A white texture times a factor is lit exactly like the flat colour of that factor; the
// untextured renderer draws what it drew before.
TEST_F(Textured, FactorMatchesTheFlatColour) {
    const Image white = filledImage(4, 4, kWhite);
    const Flat s = square();
    const std::vector<std::uint32_t> values = {0, 1, 2, 3};
    const std::vector<float> uv = {0, 1, 1, 1, 1, 0, 0, 0};
    RenderOptions o = small(96);
    o.surface = {170, 190, 215, 255};
    SurfaceTexture texture{s.offsets, s.verts, values, uv, &white};
    texture.factor = {170 / 255.0f, 190 / 255.0f, 215 / 255.0f, 1};
    const Camera camera = frameBox({-1, -1, 0}, {1, 1, 0}, 1);  // from the side: varied lighting
    Image flat, textured;
    Renderer(context(), s.polygons(), o).draw(s.positions, s.normals, camera, flat);
    Renderer(context(), s.polygons(), o, {}, texture).draw(s.positions, s.normals, camera, textured);
    int differing = 0, surface = 0;
    for (std::size_t i = 0; i < flat.rgba.size(); ++i) {
        differing += std::abs(int(flat.rgba[i]) - int(textured.rgba[i])) > 1;
        surface += flat.rgba[i] != 255;
    }
    EXPECT_EQ(differing, 0);
    EXPECT_GT(surface, 1000);
}

TEST_F(Textured, BadUvsAreRefused) {
    const Image white = filledImage(1, 1, kWhite);
    const Flat s = square();
    const std::vector<std::uint32_t> values = {0, 1, 2, 3}, shortValues = {0, 1, 2};
    const std::vector<float> uv = {0, 1, 1, 1, 1, 0, 0, 0}, fewUv = {0, 1, 1, 1}, nanUv = {0, 1, 1, NAN, 1, 0, 0, 0};
    const std::vector<std::uint32_t> beyond = {0, 1, 2, 7};
    EXPECT_THROW(Renderer(context(), s.polygons(), small(), {}, SurfaceTexture{s.offsets, s.verts, shortValues, uv, &white}),
                 std::invalid_argument);
    EXPECT_THROW(Renderer(context(), s.polygons(), small(), {}, SurfaceTexture{s.offsets, s.verts, values, fewUv, &white}),
                 std::invalid_argument);
    EXPECT_THROW(Renderer(context(), s.polygons(), small(), {}, SurfaceTexture{s.offsets, s.verts, values, nanUv, &white}),
                 std::invalid_argument);
    EXPECT_THROW(Renderer(context(), s.polygons(), small(), {}, SurfaceTexture{s.offsets, beyond, values, uv, &white}),
                 std::invalid_argument);
    Image broken = white;
    broken.rgba.pop_back();
    EXPECT_THROW(Renderer(context(), s.polygons(), small(), {}, SurfaceTexture{s.offsets, s.verts, values, uv, &broken}),
                 std::invalid_argument);
}

// ---------------------------------------------------------------------------------------
// psub render --texture

struct PsubRun {
    int status = -1;
    std::string output;  // stdout and stderr
};

PsubRun runPsub(const std::string& arguments) {
    const fs::path log = fs::temp_directory_path() / ("psub_texture_log_" + std::to_string(::getpid()));
    const std::string sanitizer = kSanitized ? std::string(test::kNoLeakCheck) + " " : "";
    const std::string command = sanitizer + PSUB_EXE + std::string(" ") + arguments + " >" + log.string() + " 2>&1";
    const int status = std::system(command.c_str());
    PsubRun run;
    run.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    run.output = text.str();
    fs::remove(log);
    return run;
}

class TextureCommand : public test::VulkanCommandTest {};

TEST_F(TextureCommand, UnreadableImagesAreNamedAndWriteNothing) {
    const std::string cube = test::dataPath("cube.obj"), out = (dir_ / "out.png").string();
    const std::string missing = (dir_ / "missing.png").string(), broken = (dir_ / "broken.png").string();
    std::ofstream(broken) << "not a png";
    for (const std::string& image : {missing, broken}) {
        const PsubRun run = runPsub("render " + cube + " -o " + out + " --levels 1 --texture " + image);
        EXPECT_EQ(run.status, 1) << run.output;
        EXPECT_NE(run.output.find(image + ": cannot"), std::string::npos) << run.output;
        EXPECT_FALSE(fs::exists(out));
    }
}

TEST_F(TextureCommand, AMeshWithoutUvsIsRefused) {
    const std::string cube = test::dataPath("cube.obj"), out = (dir_ / "out.png").string();
    const std::string image = (dir_ / "t.png").string();
    writePng(image, filledImage(2, 2, kRed));
    const PsubRun run = runPsub("render " + cube + " -o " + out + " --levels 1 --texture " + image);
    EXPECT_EQ(run.status, 1) << run.output;
    EXPECT_NE(run.output.find(cube + ": --texture needs texture coordinates"), std::string::npos) << run.output;
    EXPECT_FALSE(fs::exists(out));
    const PsubRun cc = runPsub("render " + cube + " -o " + out + " --scheme cc --texture " + image);
    EXPECT_EQ(cc.status, 2) << cc.output;
    EXPECT_FALSE(fs::exists(out));
    // Untextured, the same command draws.
    EXPECT_EQ(runPsub("render " + cube + " -o " + out + " --levels 1 --size 64x64").status, 0);
    EXPECT_TRUE(fs::exists(out));
}

TEST_F(TextureCommand, PlayRenderChecksTheTextureFirst) {
    const std::string cube = test::dataPath("cube.obj"), dir = (dir_ / "frames").string();
    const std::string missing = (dir_ / "missing.png").string();
    const PsubRun run = runPsub("play " + cube + " --levels 1 --frames 2 --render " + dir + " --texture " + missing);
    EXPECT_EQ(run.status, 1) << run.output;
    EXPECT_NE(run.output.find(missing + ": cannot open the image"), std::string::npos) << run.output;
    EXPECT_FALSE(fs::exists(fs::path(dir) / "frame_0000.png"));
}

// End to end: OBJ `vt` read, refined through the face-varying tables and drawn. A planar 4 x 4
// grid whose UVs are u = x / 4, v = y / 4 (an affine map: the P-S rules reproduce it, so the
// refined u is x / 4 everywhere) under a texture whose left half (u < 1/2) is red and right half
// blue: in every image row the red pixels lie left of the blue ones (the plane's line x = 2 is a
// straight line in the image, crossed once per row), and both colours are drawn.
TEST_F(TextureCommand, ObjUvsAreRefinedAndDrawnEndToEnd) {
    std::ostringstream obj;
    for (int j = 0; j <= 4; ++j)
        for (int i = 0; i <= 4; ++i) obj << "v " << i << ' ' << j << " 0\n";
    for (int j = 0; j <= 4; ++j)
        for (int i = 0; i <= 4; ++i) obj << "vt " << i / 4.0 << ' ' << j / 4.0 << "\n";
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            const int a = 1 + j * 5 + i, b = a + 1, c = a + 6, d = a + 5;
            obj << "f " << a << '/' << a << ' ' << b << '/' << b << ' ' << c << '/' << c << ' ' << d << '/' << d << "\n";
        }
    const std::string mesh = (dir_ / "grid_uv.obj").string(), image = (dir_ / "halves.png").string();
    const std::string out = (dir_ / "out.png").string();
    std::ofstream(mesh) << obj.str();
    Image halves = filledImage(64, 4, kRed);
    for (std::uint32_t y = 0; y < 4; ++y)
        for (std::uint32_t x = 32; x < 64; ++x) halves.setPixel(x, y, Rgba{0, 0, 255, 255});
    writePng(image, halves);
    const PsubRun run = runPsub("render " + mesh + " -o " + out + " --levels 3 --size 160x120 --texture " + image);
    ASSERT_EQ(run.status, 0) << run.output;
    const Image drawn = readPng(out);
    int redPixels = 0, bluePixels = 0;
    for (std::uint32_t y = 0; y < drawn.height; ++y) {
        int lastRed = -1, firstBlue = int(drawn.width);
        for (std::uint32_t x = 0; x < drawn.width; ++x) {
            const Rgba p = drawn.pixel(x, y);
            if (p.r > p.b + 80 && p.r > p.g + 80) lastRed = int(x), ++redPixels;
            if (p.b > p.r + 80 && p.b > p.g + 80 && firstBlue == int(drawn.width)) firstBlue = int(x);
            if (p.b > p.r + 80 && p.b > p.g + 80) ++bluePixels;
        }
        EXPECT_LT(lastRed, firstBlue) << "row " << y;
    }
    // Bound 500: a floor far under each half's share of the 160 x 120 = 19200 pixels, so that
    // both halves were drawn, not a count.
    EXPECT_GT(redPixels, 500);
    EXPECT_GT(bluePixels, 500);
}

TEST(TextureCommandHelp, TeachesTheTexture) {
    const PsubRun render = runPsub("render --help"), play = runPsub("play --help");
    EXPECT_EQ(render.status, 0);
    EXPECT_NE(render.output.find("--texture TEXT"), std::string::npos) << render.output;
    EXPECT_NE(render.output.find("--levels 6 --texture data/spot_texture.png"), std::string::npos) << render.output;
    EXPECT_EQ(play.status, 0);
    EXPECT_NE(play.output.find("--render frames/ --texture data/spot_texture.png"), std::string::npos) << play.output;
}

}  // namespace
}  // namespace psub
