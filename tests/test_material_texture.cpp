// `psub render` and `psub play --render` draw a glTF's material (base colour texture, embedded or
// external, times its factor) without --texture; --texture overrides it; a broken or missing
// image is an InputError naming the file and the image, with no output. On a generated textured
// quad and on the bundled CesiumMan. No Vulkan device fails unless PSUB_ALLOW_NO_VULKAN=1.
#include "test_support.h"

#include "psub/image.h"
#include "psub/render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

namespace {

namespace fs = std::filesystem;
using namespace psub;

constexpr Rgba kRed{255, 0, 0, 255}, kBlue{0, 0, 255, 255}, kWhite{255, 255, 255, 255};

bool isRed(Rgba p) { return p.r > p.g + 80 && p.r > p.b + 80; }
bool isBlue(Rgba p) { return p.b > p.r + 80 && p.b > p.g + 80; }
bool isGreen(Rgba p) { return p.g > p.r + 80 && p.g > p.b + 80; }

int countIf(const Image& image, bool (*test)(Rgba)) {
    int count = 0;
    for (std::uint32_t y = 0; y < image.height; ++y)
        for (std::uint32_t x = 0; x < image.width; ++x) count += test(image.pixel(x, y)) ? 1 : 0;
    return count;
}

// 64 x 4 pixels: the left half (u < 1/2) red, the right half blue.
std::string halvesPng(const fs::path& scratch) {
    Image halves = filledImage(64, 4, kRed);
    for (std::uint32_t y = 0; y < 4; ++y)
        for (std::uint32_t x = 32; x < 64; ++x) halves.setPixel(x, y, kBlue);
    return encodePng((scratch / "halves.png").string(), halves);
}

// The unit quad in the plane z = 0 (two triangles) with u = x, v = 1 - y, as glTF.
struct Quad {
    enum class Image { Embedded, External, None };
    Image image = Image::Embedded;
    std::string imageBytes;            // Embedded: the image's bytes
    std::string uri = "halves.png";    // External: the image's file
    std::string factor = "[1, 1, 1, 1]";  // empty: no baseColorFactor (glTF's default white)
    bool material = true;
    bool uvs = true;
};

std::string quadBin() {
    const float positions[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    const float uvs[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    const std::uint16_t indices[6] = {0, 1, 2, 0, 2, 3};
    std::string bytes(92, '\0');
    std::memcpy(bytes.data(), positions, 48);
    std::memcpy(bytes.data() + 48, uvs, 32);
    std::memcpy(bytes.data() + 80, indices, 12);
    return bytes;
}

// The quad as a .glb (buffer and embedded image in its binary chunk).
std::string quadGlb(const Quad& q) {
    std::string bin = quadBin();
    const std::size_t imageOffset = bin.size();
    if (q.image == Quad::Image::Embedded) bin += q.imageBytes;
    while (bin.size() % 4) bin += '\0';
    std::string json = "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],"
                       " \"nodes\": [{\"mesh\": 0}],\n\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0";
    if (q.uvs) json += ", \"TEXCOORD_0\": 1";
    json += "}, \"indices\": 2";
    if (q.material) json += ", \"material\": 0";
    json += "}]}],\n";
    if (q.material) {
        std::string pbr = q.factor.empty() ? "" : "\"baseColorFactor\": " + q.factor;
        if (q.image != Quad::Image::None) pbr += std::string(pbr.empty() ? "" : ", ") + "\"baseColorTexture\": {\"index\": 0}";
        json += "\"materials\": [{\"name\": \"halves\", \"pbrMetallicRoughness\": {" + pbr + "}}],\n";
        if (q.image != Quad::Image::None) json += "\"textures\": [{\"source\": 0}],\n";
        if (q.image == Quad::Image::Embedded)
            json += "\"images\": [{\"name\": \"halves\", \"bufferView\": 3, \"mimeType\": \"image/png\"}],\n";
        if (q.image == Quad::Image::External) json += "\"images\": [{\"uri\": \"" + q.uri + "\"}],\n";
    }
    json += "\"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\","
            " \"min\": [0, 0, 0], \"max\": [1, 1, 0]},\n"
            " {\"bufferView\": 1, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC2\"},\n"
            " {\"bufferView\": 2, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"}],\n"
            "\"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 48},"
            " {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 32},"
            " {\"buffer\": 0, \"byteOffset\": 80, \"byteLength\": 12}";
    if (q.image == Quad::Image::Embedded)
        json += ", {\"buffer\": 0, \"byteOffset\": " + std::to_string(imageOffset) +
                ", \"byteLength\": " + std::to_string(q.imageBytes.size()) + "}";
    json += "],\n\"buffers\": [{\"byteLength\": " + std::to_string(bin.size()) + "}]}\n";
    return test::glb(json, bin);
}

class MaterialTexture : public ::testing::Test {
protected:
    void SetUp() override {
        try {
            VulkanContext probe;
        } catch (const VulkanError& e) {
            if (test::noVulkanAllowed()) GTEST_SKIP() << "no Vulkan device (allowed by PSUB_ALLOW_NO_VULKAN=1): " << e.what();
            FAIL() << "no Vulkan device: " << e.what() << " (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
        }
        ASSERT_FALSE(scratch_.path().empty());
        png_ = halvesPng(scratch_.path());
    }

    std::string write(const std::string& name, const std::string& bytes) {
        test::writeFile(scratch_ / name, bytes);
        return (scratch_ / name).string();
    }
    std::string out(const std::string& name) const { return (scratch_ / name).string(); }

    // `psub render FILE -o NAME.png` of the quad, 2 steps, 96 x 96; the image (empty on failure).
    Image render(const std::string& file, const std::string& name, const std::string& more = "") {
        run_ = test::runPsub(scratch_, "render " + test::quoted(file) + " -o " + test::quoted(out(name)) +
                                           " --levels 2 --size 96x96 " + more);
        if (run_.status != 0) return {};
        return readPng(out(name));
    }

    test::ScratchDir scratch_;
    std::string png_;
    test::PsubRun run_;
};

// Embedded PNG: both halves of the texture are drawn, red left of blue in every row (u = x),
// and the untextured quad (same file without the material) has neither colour.
TEST_F(MaterialTexture, EmbeddedTextureIsDrawnWithoutTextureOption) {
    Quad q;
    q.imageBytes = png_;
    const std::string textured = write("textured.glb", quadGlb(q));
    q.material = false;
    const std::string plain = write("plain.glb", quadGlb(q));
    const Image drawn = render(textured, "textured.png");
    ASSERT_EQ(run_.status, 0) << run_.out << run_.err;
    EXPECT_TRUE(test::contains(run_.out, "textured with the base colour image 0 'halves' of material 'halves'")) << run_.out;
    const Image untextured = render(plain, "plain.png");
    ASSERT_EQ(run_.status, 0) << run_.out << run_.err;
    // Bounds 300 and 600: floors well under the quad's share of the 96 x 96 = 9216 pixels, so that
    // both halves (and the texture at all) were drawn; not exact counts.
    EXPECT_GT(countIf(drawn, isRed), 300);
    EXPECT_GT(countIf(drawn, isBlue), 300);
    EXPECT_EQ(countIf(untextured, isRed), 0);
    int differing = 0;
    for (std::uint32_t y = 0; y < drawn.height; ++y) {
        int lastRed = -1, firstBlue = int(drawn.width);
        for (std::uint32_t x = 0; x < drawn.width; ++x) {
            const Rgba p = drawn.pixel(x, y);
            if (isRed(p)) lastRed = int(x);
            if (isBlue(p) && firstBlue == int(drawn.width)) firstBlue = int(x);
            differing += p == untextured.pixel(x, y) ? 0 : 1;
        }
        EXPECT_LT(lastRed, firstBlue) << "row " << y;
    }
    EXPECT_GT(differing, 600);
}

// External image file and baseColorFactor: a white image times green is green.
TEST_F(MaterialTexture, ExternalImageTimesFactor) {
    write("white.png", encodePng("white.png", filledImage(4, 4, kWhite)));
    Quad q;
    q.image = Quad::Image::External;
    q.uri = "white.png";
    q.factor = "[0, 1, 0, 1]";
    const std::string file = write("green.glb", quadGlb(q));
    const Image drawn = render(file, "green.png");
    ASSERT_EQ(run_.status, 0) << run_.out << run_.err;
    EXPECT_GT(countIf(drawn, isGreen), 1000);
    EXPECT_EQ(countIf(drawn, isRed), 0);
}

// --texture replaces the material's image.
TEST_F(MaterialTexture, TextureOptionOverridesTheMaterial) {
    Quad q;
    q.imageBytes = png_;
    const std::string file = write("textured.glb", quadGlb(q));
    const std::string blue = write("blue.png", encodePng("blue.png", filledImage(4, 4, kBlue)));
    const Image drawn = render(file, "blue.png", "--texture " + test::quoted(blue));
    ASSERT_EQ(run_.status, 0) << run_.out << run_.err;
    EXPECT_TRUE(test::contains(run_.out, "textured with " + blue)) << run_.out;
    EXPECT_EQ(countIf(drawn, isRed), 0);
    EXPECT_GT(countIf(drawn, isBlue), 1000);
}

// A broken embedded image and a missing external one: exit 1, one line naming the file and the
// image, no picture and no frame.
TEST_F(MaterialTexture, BrokenOrMissingImageNamesFileAndImage) {
    Quad broken;
    broken.imageBytes = png_.substr(0, 40);  // PNG magic, then cut off
    const std::string brokenFile = write("broken.glb", quadGlb(broken));
    Quad missing;
    missing.image = Quad::Image::External;
    missing.uri = "nowhere.png";
    const std::string missingFile = write("missing.glb", quadGlb(missing));
    const struct {
        std::string file, image;
    } cases[] = {{brokenFile, "base colour image 0 'halves'"}, {missingFile, "uri 'nowhere.png'"}};
    for (const auto& c : cases) {
        render(c.file, "out.png");
        EXPECT_EQ(run_.status, 1) << run_.out << run_.err;
        const std::string line = test::oneLine(run_);
        EXPECT_TRUE(test::contains(line, c.file + ": ")) << line;
        EXPECT_TRUE(test::contains(line, c.image)) << line;
        EXPECT_FALSE(fs::exists(out("out.png")));
        const test::PsubRun play = test::runPsub(scratch_, "play " + test::quoted(c.file) + " --levels 1 --frames 1 --render " +
                                                              test::quoted(out("frames")) + " --size 32x32");
        EXPECT_EQ(play.status, 1) << play.out << play.err;
        EXPECT_TRUE(test::contains(play.err, c.image)) << play.err;
        EXPECT_FALSE(fs::exists(out("frames") + "/frame_0000.png"));
    }
}

// A material texture on a mesh without TEXCOORD_0: a warning, and the quad drawn untextured.
TEST_F(MaterialTexture, WithoutUvsTheTextureIsLeftOutWithAWarning) {
    Quad q;
    q.imageBytes = png_;
    q.uvs = false;
    const std::string file = write("no_uv.glb", quadGlb(q));
    const Image drawn = render(file, "no_uv.png");
    ASSERT_EQ(run_.status, 0) << run_.out << run_.err;
    EXPECT_TRUE(test::contains(run_.err, "base colour image 0 'halves' is not drawn: the mesh has no TEXCOORD_0"))
        << run_.err;
    EXPECT_EQ(countIf(drawn, isRed), 0);
}

// A material with a base colour factor and no texture draws the factor's colour (lit, as the
// textured path draws factor x texture), in `psub render` and `psub play --render`; without the
// factor (glTF's default white) or without a material, the renderer's default colour.
TEST_F(MaterialTexture, FactorWithoutTextureIsDrawnInItsColour) {
    Quad q;
    q.image = Quad::Image::None;
    q.factor = "[1, 0, 0, 1]";
    const std::string red = write("red.glb", quadGlb(q));
    q.factor = "";
    const std::string white = write("white.glb", quadGlb(q));
    q.material = false;
    const std::string plain = write("plain.glb", quadGlb(q));
    const Image drawnRed = render(red, "red.png");
    ASSERT_EQ(run_.status, 0) << run_.out << run_.err;
    const Image drawnWhite = render(white, "white.png");
    ASSERT_EQ(run_.status, 0) << run_.out << run_.err;
    const Image drawnPlain = render(plain, "plain.png");
    ASSERT_EQ(run_.status, 0) << run_.out << run_.err;
    // Bound 1000: a floor well under the quad's share of the 96 x 96 = 9216 pixels; not exact.
    EXPECT_GT(countIf(drawnRed, isRed), 1000);
    EXPECT_EQ(countIf(drawnPlain, isRed), 0);
    EXPECT_TRUE(drawnWhite.rgba == drawnPlain.rgba) << "no factor: the default colour, as without a material";
    // Where the plain quad is drawn (not background white), the red one is red.
    int model = 0, redOnModel = 0;
    for (std::uint32_t y = 0; y < drawnPlain.height; ++y)
        for (std::uint32_t x = 0; x < drawnPlain.width; ++x) {
            if (drawnPlain.pixel(x, y) == kWhite) continue;
            ++model;
            redOnModel += isRed(drawnRed.pixel(x, y)) ? 1 : 0;
        }
    EXPECT_GT(model, 1000);
    // Bound 0.9: all but the anti-aliased silhouette's pixels.
    EXPECT_GT(redOnModel, 0.9 * model) << redOnModel << " of " << model;
    const test::PsubRun play = test::runPsub(scratch_, "play " + test::quoted(red) + " --levels 2 --frames 1 --render " +
                                                           test::quoted(out("frames")) + " --size 96x96");
    ASSERT_EQ(play.status, 0) << play.out << play.err;
    EXPECT_GT(countIf(readPng(out("frames") + "/frame_0000.png"), isRed), 1000);
}

// Pixels of `a` and `b` with some channel more than 2 levels apart.
int differingPixels(const Image& a, const Image& b) {
    EXPECT_EQ(a.rgba.size(), b.rgba.size());
    int differing = 0;
    for (std::size_t at = 0; at + 3 < std::min(a.rgba.size(), b.rgba.size()); at += 4) {
        int worst = 0;
        for (std::size_t k = 0; k < 4; ++k) worst = std::max(worst, std::abs(int(a.rgba[at + k]) - int(b.rgba[at + k])));
        differing += worst > 2;
    }
    return differing;
}

// `psub play ARGS --form FORM --render DIR --size 160x160` into DIR = out(FORM); the run.
test::PsubRun playForm(const test::ScratchDir& scratch, const std::string& args, const std::string& form,
                       const std::string& dir) {
    return test::runPsub(scratch, "play " + args + " --form " + form + " --render " + test::quoted(dir) + " --size 160x160");
}

// The tiled form draws textured frames (its faces name its drawing order: TiledTable::uvFace...)
// equal to the per-level form's: the textured Spot cage (--texture) at odd and even levels (5%
// and 15% of its points tiled), and the bundled CesiumMan's material texture, walking (its
// triangle cage leaves no regular tiles: all fallback, its faces still in the tiled order). Bound 4 pixels (as the CPU-against-Vulkan
// picture of test_render.cpp): float positions of the two forms differ by a few ulps, which can
// move only pixels that an edge passes within rounding of. And auto, textured, times both forms.
TEST_F(MaterialTexture, TiledFormDrawsThePerLevelTexturedFrames) {
    const std::string spot = test::quoted(test::dataPath("spot_control_mesh_uv.obj")) + " --texture " +
                             test::quoted(test::dataPath("spot_texture.png")) + " --frames 2 --anim twist";
    const std::string cesium = test::quoted(test::dataPath("CesiumMan.glb")) + " --frames 2 --levels 3";
    for (const std::string& args : {spot + " --levels 3", spot + " --levels 4", cesium}) {
        const test::PsubRun tiled = playForm(scratch_, args, "tiled", out("tiled"));
        ASSERT_EQ(tiled.status, 0) << args << "\n" << tiled.out << tiled.err;
        EXPECT_TRUE(test::contains(tiled.out, "Table form: tiled (forced)")) << tiled.out;
        const test::PsubRun perLevel = playForm(scratch_, args, "per-level", out("per-level"));
        ASSERT_EQ(perLevel.status, 0) << args << "\n" << perLevel.out << perLevel.err;
        for (const std::string frame : {"/frame_0000.png", "/frame_0001.png"}) {
            const Image a = readPng(out("tiled") + frame), b = readPng(out("per-level") + frame);
            EXPECT_LE(differingPixels(a, b), 4) << args << frame;
            // Textured at all: the default surface colour (170, 190, 215), lit or blended with the
            // white background, keeps blue above red and green; Spot's pink and CesiumMan's green
            // do not. Bound 50: a floor, not a count.
            auto notDefault = [](Rgba p) { return p.r > p.b + 8 || p.g > p.b + 8; };
            int coloured = 0;
            for (std::uint32_t y = 0; y < a.height; ++y)
                for (std::uint32_t x = 0; x < a.width; ++x) coloured += notDefault(a.pixel(x, y)) ? 1 : 0;
            EXPECT_GT(coloured, 50) << args << frame << ": not textured";
        }
        fs::remove_all(out("tiled"));
        fs::remove_all(out("per-level"));
    }
    const test::PsubRun automatic = playForm(scratch_, spot + " --levels 4", "auto", out("auto"));
    ASSERT_EQ(automatic.status, 0) << automatic.out << automatic.err;
    EXPECT_TRUE(test::contains(automatic.out, "% of the points tiled; rest pose ")) << automatic.out;
}

// The bundled CesiumMan walks textured: a frame of `psub play --render` shows the texture's blue
// and green (the untextured surface is grey-blue, neither), and frames differ as it walks.
TEST_F(MaterialTexture, CesiumManFramesAreTextured) {
    const std::string dir = out("frames");
    const test::PsubRun run = test::runPsub(scratch_, "play " + test::quoted(test::dataPath("CesiumMan.glb")) +
                                                          " --levels 1 --frames 8 --render " + test::quoted(dir) +
                                                          " --size 160x160");
    ASSERT_EQ(run.status, 0) << run.out << run.err;
    const Image first = readPng(dir + "/frame_0000.png"), later = readPng(dir + "/frame_0007.png");
    auto vividBlue = [](Rgba p) { return p.b > p.r + 60 && p.b > p.g + 20; };
    auto vividGreen = [](Rgba p) { return p.g > p.r + 30 && p.g > p.b + 30; };
    int blue = 0, green = 0, differing = 0;
    for (std::uint32_t y = 0; y < first.height; ++y)
        for (std::uint32_t x = 0; x < first.width; ++x) {
            blue += vividBlue(first.pixel(x, y)) ? 1 : 0;
            green += vividGreen(first.pixel(x, y)) ? 1 : 0;
            differing += first.pixel(x, y) == later.pixel(x, y) ? 0 : 1;
        }
    // Bounds 50 and 10: floors that the texture's blue and green show at all in 160 x 160 pixels;
    // not exact counts.
    EXPECT_GT(blue, 50);
    EXPECT_GT(green, 10);
    EXPECT_GT(differing, 100);
    // The same frame untextured (--texture of a plain white image) has no green.
    const std::string white = write("white.png", encodePng("white.png", filledImage(2, 2, kWhite)));
    const test::PsubRun plain = test::runPsub(scratch_, "play " + test::quoted(test::dataPath("CesiumMan.glb")) +
                                                            " --levels 1 --frames 1 --render " + test::quoted(out("plain")) +
                                                            " --size 160x160 --texture " + test::quoted(white));
    ASSERT_EQ(plain.status, 0) << plain.out << plain.err;
    const Image untextured = readPng(out("plain") + "/frame_0000.png");
    int plainGreen = 0;
    for (std::uint32_t y = 0; y < untextured.height; ++y)
        for (std::uint32_t x = 0; x < untextured.width; ++x) plainGreen += vividGreen(untextured.pixel(x, y)) ? 1 : 0;
    EXPECT_EQ(plainGreen, 0);
}

}  // namespace
