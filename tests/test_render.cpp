// The offscreen renderer (psub_render) on lavapipe (or any device) with the Khronos validation
// layer on in every test: the refined cube renders, its silhouette matches the refined
// triangles projected on the CPU with the camera's matrix, CPU- and Vulkan-evaluated positions
// give the same picture, wireframes add dark lines, draws are deterministic, one renderer
// switches wireframe modes, vertices written in its mapped buffers draw as copied ones; the
// camera frames its box; PNG files round-trip and fail cleanly; captions and panels; `psub
// render`. Each test fails on any validation message, and without a device unless
// PSUB_ALLOW_NO_VULKAN=1.
#include "psub/evaluator.h"
#include "psub/render.h"
#include "psub/stencils.h"
#include "psub/vulkan_evaluator.h"
#include "test_support.h"
#include "vulkan_test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>

#include <dlfcn.h>
#include <sys/wait.h>

namespace psub {
namespace {

namespace fs = std::filesystem;

using test::kSanitized;

// Under the sanitizers, Mesa's lavapipe stays loaded for the whole run: its first draw
// allocates process-wide state it never frees, the loader unloads the driver with each
// instance, and LeakSanitizer then reports that state (112 bytes from an unknown module) as
// leaked. Kept loaded, it stays reachable. Unsanitized builds and other drivers: no effect.
[[maybe_unused]] const bool kLavapipePinned = kSanitized && ::dlopen("libvulkan_lvp.so", RTLD_NOW | RTLD_NODELETE);

// Every test: its own validated context, no validation message (vulkan_test_support.h).
class Render : public test::ValidatedVulkanTest {};

// A refined model with positions and normals from the CPU evaluator (float).
struct Refined {
    test::Loaded loaded;
    Refinement refinement;
    std::vector<float> control, positions, normals;

    Polygons surface() const { return polygonsOf(refinement.surface); }
    Polygons cage() const {
        return {loaded.mesh.faces.vertexCount, loaded.mesh.faces.offsets, loaded.mesh.faces.verts};
    }
};

Refined refined(const std::string& path, int levels) {
    Refined r{test::load(path), {}, {}, {}, {}};
    RefineOptions options;
    options.levels = levels;
    r.refinement = refine(r.loaded.mesh, r.loaded.checked.connectivity, options);
    r.control.assign(r.loaded.mesh.positions.begin(), r.loaded.mesh.positions.end());
    CpuEvaluator<float> evaluator(r.refinement.perLevel, r.refinement.factorized, r.refinement.surface,
                                  TableForm::PerLevel);
    r.positions.resize(3 * std::size_t(evaluator.refinedCount()));
    r.normals.resize(r.positions.size());
    evaluator.evaluate(r.control, r.positions);
    evaluator.normals(r.positions, r.normals);
    return r;
}

const Refined& cube4() {
    static const Refined r = refined(test::dataPath("cube.obj"), 4);
    return r;
}

RenderOptions small(Wireframe wireframe = Wireframe::None, std::uint32_t samples = 4) {
    RenderOptions o;
    o.width = 256, o.height = 256, o.wireframe = wireframe, o.samples = samples;
    return o;
}

Camera cameraFor(std::span<const float> positions, const RenderOptions& o) {
    Box box;
    box.extend(positions);
    return frameBox(box, float(o.width) / float(o.height));
}

std::size_t countPixels(const Image& image, auto predicate) {
    std::size_t count = 0;
    for (std::uint32_t y = 0; y < image.height; ++y)
        for (std::uint32_t x = 0; x < image.width; ++x) count += predicate(image.pixel(x, y)) ? 1 : 0;
    return count;
}

std::size_t notBackground(const Image& image, Rgba background) {
    return countPixels(image, [&](Rgba p) { return !(p == background); });
}

std::size_t dark(const Image& image) {
    return countPixels(image, [](Rgba p) { return int(p.r) + int(p.g) + int(p.b) < 3 * 80; });
}

// clip = M * (p, 1), M column-major.
std::array<double, 4> clip(const std::array<float, 16>& m, const float* p) {
    std::array<double, 4> c{};
    for (int row = 0; row < 4; ++row)
        c[row] = double(m[row]) * p[0] + double(m[4 + row]) * p[1] + double(m[8 + row]) * p[2] + double(m[12 + row]);
    return c;
}

// Pixel coordinates (x right, y down from the top row) as the camera's documentation says.
std::array<double, 2> toPixel(const std::array<double, 4>& c, std::uint32_t width, std::uint32_t height) {
    return {(c[0] / c[3] + 1) / 2 * width, (c[1] / c[3] + 1) / 2 * height};
}

// Pixel centres inside any of the faces' fan triangles, projected with viewProjection.
std::vector<bool> projectedCoverage(const Refined& r, const Camera& camera, std::uint32_t width, std::uint32_t height) {
    std::vector<bool> covered(std::size_t(width) * height, false);
    const SurfaceTable& s = r.refinement.surface;
    auto pixelOf = [&](std::uint32_t v) {
        return toPixel(clip(camera.viewProjection, &r.positions[3 * v]), width, height);
    };
    for (std::size_t f = 0; f + 1 < s.faceOffsets.size(); ++f)
        for (std::uint32_t i = s.faceOffsets[f] + 1; i + 1 < s.faceOffsets[f + 1]; ++i) {
            const auto a = pixelOf(s.faceVerts[s.faceOffsets[f]]), b = pixelOf(s.faceVerts[i]),
                       c = pixelOf(s.faceVerts[i + 1]);
            const double area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            if (area == 0) continue;
            const int x0 = std::max(0, int(std::floor(std::min({a[0], b[0], c[0]}))));
            const int x1 = std::min(int(width) - 1, int(std::ceil(std::max({a[0], b[0], c[0]}))));
            const int y0 = std::max(0, int(std::floor(std::min({a[1], b[1], c[1]}))));
            const int y1 = std::min(int(height) - 1, int(std::ceil(std::max({a[1], b[1], c[1]}))));
            for (int y = y0; y <= y1; ++y)
                for (int x = x0; x <= x1; ++x) {
                    const double px = x + 0.5, py = y + 0.5;
                    auto edge = [&](const std::array<double, 2>& p, const std::array<double, 2>& q) {
                        return ((q[0] - p[0]) * (py - p[1]) - (q[1] - p[1]) * (px - p[0])) * (area > 0 ? 1 : -1);
                    };
                    if (edge(a, b) >= 0 && edge(b, c) >= 0 && edge(c, a) >= 0) covered[std::size_t(y) * width + x] = true;
                }
        }
    return covered;
}

TEST_F(Render, RefinedCubeRendersANonEmptyImage) {
    const Refined& cube = cube4();
    const RenderOptions o = small();
    Renderer renderer(context(), cube.surface(), o);
    EXPECT_EQ(renderer.triangleCount(), 2 * (cube.refinement.surface.faceOffsets.size() - 1));
    Image image;
    renderer.draw(cube.positions, cube.normals, cameraFor(cube.positions, o), image);
    // small(): 256 x 256 RGBA. The framed cube covers most of it; a twentieth is the bound.
    ASSERT_EQ(image.width, 256u);
    ASSERT_EQ(image.height, 256u);
    ASSERT_EQ(image.rgba.size(), 256u * 256u * 4u);
    EXPECT_GT(notBackground(image, o.background), 256u * 256u / 20);
    EXPECT_FALSE(image.pixel(128, 128) == o.background) << "the centre is on the cube";
    EXPECT_TRUE(image.pixel(0, 0) == o.background) << "a corner is background";
    const DrawTimes t = renderer.lastTimes();
    EXPECT_GT(t.renderMs, 0);
    EXPECT_GT(t.readbackMs, 0);
}

TEST_F(Render, SilhouetteCoversTheFractionOfTheProjectedTriangles) {
    const Refined& cube = cube4();
    const RenderOptions o = small(Wireframe::None, 1);  // one sample: a pixel is covered when its centre is
    const Camera camera = cameraFor(cube.positions, o);
    Renderer renderer(context(), cube.surface(), o);
    Image image;
    renderer.draw(cube.positions, cube.normals, camera, image);
    const std::vector<bool> expected = projectedCoverage(cube, camera, o.width, o.height);
    std::size_t expectedCount = 0, mismatched = 0;
    for (std::uint32_t y = 0; y < o.height; ++y)
        for (std::uint32_t x = 0; x < o.width; ++x) {
            const bool want = expected[std::size_t(y) * o.width + x], got = !(image.pixel(x, y) == o.background);
            expectedCount += want;
            mismatched += want != got;
        }
    const double total = double(o.width) * o.height;
    const double expectedFraction = double(expectedCount) / total;
    const double renderedFraction = double(notBackground(image, o.background)) / total;
    EXPECT_GT(expectedFraction, 0.1);
    EXPECT_LT(expectedFraction, 0.9);
    // Bounds, not measurements: only pixels whose centre lies within rounding of an edge may
    // differ; the silhouette's few hundred edge pixels are under 1% of the 65536 (0.5% of the
    // image allowed) and under 1% of the covered pixels.
    EXPECT_NEAR(renderedFraction, expectedFraction, 0.005)
        << "expected " << expectedFraction << ", rendered " << renderedFraction;
    EXPECT_LE(double(mismatched), 0.01 * double(expectedCount)) << mismatched << " pixels differ from the CPU's coverage";
}

TEST_F(Render, CpuAndVulkanEvaluatorsGiveTheSamePicture) {
    const Refined& cube = cube4();
    const Refinement& r = cube.refinement;
    VulkanEvaluator gpu(context(), r.perLevel, r.factorized, r.surface, TableForm::PerLevel);
    std::vector<float> positions(cube.positions.size()), normals(cube.normals.size());
    gpu.evaluate(cube.control, positions, normals);
    const RenderOptions o = small(Wireframe::Refined);
    const Camera camera = cameraFor(cube.positions, o);
    Renderer renderer(context(), cube.surface(), o);
    Image fromCpu, fromVulkan;
    renderer.draw(cube.positions, cube.normals, camera, fromCpu);
    renderer.draw(positions, normals, camera, fromVulkan);
    std::size_t differing = 0;  // pixels with a channel more than 2 levels apart
    for (std::size_t at = 0; at < fromCpu.rgba.size(); at += 4) {
        int worst = 0;
        for (std::size_t k = 0; k < 4; ++k)
            worst = std::max(worst, std::abs(int(fromCpu.rgba[at + k]) - int(fromVulkan.rgba[at + k])));
        differing += worst > 2;
    }
    // Bound: float CPU and Vulkan positions differ by a few ulps, which can move only pixels
    // that an edge passes within rounding of: a handful, 4 allowed.
    EXPECT_LE(differing, 4u);
}

// Pixels clearly darker in `lined` than in `plain`.
std::size_t darkened(const Image& plain, const Image& lined) {
    std::size_t count = 0;
    for (std::size_t at = 0; at < plain.rgba.size(); at += 4) {
        const int before = plain.rgba[at] + plain.rgba[at + 1] + plain.rgba[at + 2];
        const int after = lined.rgba[at] + lined.rgba[at + 1] + lined.rgba[at + 2];
        count += after < before - 3 * 40;
    }
    return count;
}

TEST_F(Render, WireframesAddDarkPixels) {
    const Refined& cube = cube4();
    auto draw = [&](Wireframe wireframe, const Camera& camera) {
        Renderer renderer(context(), cube.surface(), small(wireframe), cube.cage());
        if (wireframe == Wireframe::Refined) {
            EXPECT_EQ(renderer.lineCount(), renderer.triangleCount()) << "closed quad mesh: edges = 2 faces = triangles";
        }
        if (wireframe == Wireframe::Control) {
            EXPECT_EQ(renderer.lineCount(), 12u) << "a cube has 12 edges";
        }
        renderer.setControlPositions(cube.control);
        Image image;
        renderer.draw(cube.positions, cube.normals, camera, image);
        return image;
    };
    const Camera onSurface = cameraFor(cube.positions, small());
    // Bounds: the refined cube's hundreds of edges cross the 256 x 256 image, thousands of
    // pixels; the cage's 12 edges at least a few hundred.
    EXPECT_GT(darkened(draw(Wireframe::None, onSurface), draw(Wireframe::Refined, onSurface)), 1000u);
    Box box;  // the cage and the surface in view
    box.extend(cube.control);
    box.extend(cube.positions);
    const Camera withCage = frameBox(box, 1.0f);
    EXPECT_GT(darkened(draw(Wireframe::None, withCage), draw(Wireframe::Control, withCage)), 300u);
}

TEST_F(Render, ControlWireframeFollowsItsPositions) {
    const Refined& cube = cube4();
    const RenderOptions o = small(Wireframe::Control);
    Renderer renderer(context(), cube.surface(), o, cube.cage());
    const Camera camera = cameraFor(cube.control, o);
    Image before, after;
    renderer.setControlPositions(cube.control);
    renderer.draw(cube.positions, cube.normals, camera, before);
    std::vector<float> shrunk(cube.control);
    for (float& v : shrunk) v *= 0.5f;  // inside the surface: hidden
    renderer.setControlPositions(shrunk);
    renderer.draw(cube.positions, cube.normals, camera, after);
    EXPECT_LT(dark(after) + 100, dark(before));
}

TEST_F(Render, DrawingTwiceGivesIdenticalImagesInTheSameBuffer) {
    const Refined& cube = cube4();
    const RenderOptions o = small(Wireframe::Refined);
    Renderer renderer(context(), cube.surface(), o);
    const Camera camera = cameraFor(cube.positions, o);
    Image image;
    renderer.draw(cube.positions, cube.normals, camera, image);
    const Image first = image;
    const std::uint8_t* storage = image.rgba.data();
    renderer.draw(cube.positions, cube.normals, camera, image);
    EXPECT_EQ(image.rgba.data(), storage) << "the caller's image is reused, not reallocated";
    EXPECT_TRUE(image.rgba == first.rgba);
}

// One renderer with every wireframe mode (psub view switches with `w`) draws, per mode, the
// very bytes of a renderer made for that mode alone; its line count follows the mode.
TEST_F(Render, EveryWireframeRendererDrawsAsTheOneModeRenderers) {
    const Refined& cube = cube4();
    RenderOptions every = small();
    every.everyWireframe = true;
    Renderer all(context(), cube.surface(), every, cube.cage());
    all.setControlPositions(cube.control);
    Box box;
    box.extend(cube.control);
    const Camera camera = frameBox(box, 1.0f);
    for (Wireframe mode : {Wireframe::Refined, Wireframe::Control, Wireframe::None}) {
        Renderer one(context(), cube.surface(), small(mode), cube.cage());
        one.setControlPositions(cube.control);
        Image expected, got;
        one.draw(cube.positions, cube.normals, camera, expected);
        all.setWireframe(mode);
        all.draw(cube.positions, cube.normals, camera, got);
        EXPECT_TRUE(got.rgba == expected.rgba) << "wireframe mode " << int(mode);
        EXPECT_EQ(all.lineCount(), one.lineCount()) << "wireframe mode " << int(mode);
    }
    all.setWireframe(Wireframe::Control);
    EXPECT_EQ(all.lineCount(), 12u) << "a cube has 12 edges";
    all.setWireframe(Wireframe::None);
    EXPECT_EQ(all.lineCount(), 0u);
    Renderer single(context(), cube.surface(), small(Wireframe::Refined), cube.cage());
    EXPECT_THROW(single.setWireframe(Wireframe::None), std::invalid_argument) << "made for one mode";
    single.setWireframe(Wireframe::Refined);
    Renderer noCage(context(), cube.surface(), every);
    EXPECT_THROW(noCage.setWireframe(Wireframe::Control), std::invalid_argument) << "no control faces given";
}

// Vertices written straight into the mapped buffers (psub view's direct CPU path) draw the
// same bytes as the same values given to draw(), which copies them there.
TEST_F(Render, WrittenVerticesDrawAsCopiedOnes) {
    const Refined& cube = cube4();
    RenderOptions cached = small(Wireframe::Refined);
    cached.cachedVertices = true;
    Renderer written(context(), cube.surface(), cached), copied(context(), cube.surface(), small(Wireframe::Refined));
    const std::span<float> positions = written.mappedPositions(), normals = written.mappedNormals();
    ASSERT_EQ(positions.size(), cube.positions.size());
    ASSERT_EQ(normals.size(), cube.normals.size());
    std::copy(cube.positions.begin(), cube.positions.end(), positions.begin());
    std::copy(cube.normals.begin(), cube.normals.end(), normals.begin());
    const Camera camera = cameraFor(cube.positions, cached);
    Image expected, got;
    copied.draw(cube.positions, cube.normals, camera, expected);
    written.drawWritten(camera, got);
    EXPECT_GT(notBackground(got, cached.background), 1000u);
    EXPECT_TRUE(got.rgba == expected.rgba);
    for (float& v : positions) v *= 0.5f;  // the next draw sees what is written now
    written.drawWritten(camera, got);
    EXPECT_FALSE(got.rgba == expected.rgba);
}

TEST_F(Render, AnyPolygonIsDrawnAsAFan) {
    // A regular hexagon and a triangle beside it, flat in z = 0.
    std::vector<float> positions, normals;
    std::vector<std::uint32_t> offsets{0}, verts;
    for (int i = 0; i < 6; ++i) {
        const double angle = 2 * M_PI * i / 6;
        positions.insert(positions.end(), {float(std::cos(angle)), float(std::sin(angle)), 0.0f});
        verts.push_back(std::uint32_t(i));
    }
    offsets.push_back(6);
    positions.insert(positions.end(), {1.5f, 0, 0, 2.5f, 0, 0, 2.0f, 1, 0});
    verts.insert(verts.end(), {6, 7, 8});
    offsets.push_back(9);
    for (int v = 0; v < 9; ++v) normals.insert(normals.end(), {0, 0, 1});
    const RenderOptions o = small(Wireframe::None, 1);
    Renderer renderer(context(), Polygons{9, offsets, verts}, o);
    EXPECT_EQ(renderer.triangleCount(), 5u);  // the hexagon fanned into 4, and the triangle
    const Camera camera = cameraFor(positions, o);
    Image image;
    renderer.draw(positions, normals, camera, image);
    // The hexagon's projection is convex: count pixel centres inside it directly.
    std::array<std::array<double, 2>, 6> hexagon;
    for (int i = 0; i < 6; ++i) hexagon[i] = toPixel(clip(camera.viewProjection, &positions[3 * i]), o.width, o.height);
    std::size_t inside = 0, drawnInside = 0;
    for (std::uint32_t y = 0; y < o.height; ++y)
        for (std::uint32_t x = 0; x < o.width; ++x) {
            int positive = 0, negative = 0;
            for (int i = 0; i < 6; ++i) {
                const auto& p = hexagon[i];
                const auto& q = hexagon[(i + 1) % 6];
                const double e = (q[0] - p[0]) * (y + 0.5 - p[1]) - (q[1] - p[1]) * (x + 0.5 - p[0]);
                positive += e > 0, negative += e < 0;
            }
            if (positive == 6 || negative == 6) {
                ++inside;
                drawnInside += !(image.pixel(x, y) == o.background);
            }
        }
    EXPECT_GT(inside, 1000u);
    EXPECT_GE(double(drawnInside), 0.99 * double(inside));
}

TEST_F(Render, RejectsInconsistentPolygonsAndSizes) {
    const std::vector<std::uint32_t> offsets{0, 3}, verts{0, 1, 5};
    EXPECT_THROW(Renderer(context(), Polygons{3, offsets, verts}, small()), std::invalid_argument);
    const std::vector<std::uint32_t> shortOffsets{0, 2}, triangle{0, 1, 2};
    EXPECT_THROW(Renderer(context(), Polygons{3, shortOffsets, triangle}, small()), std::invalid_argument);
    RenderOptions empty = small();
    empty.width = 0;
    EXPECT_THROW(Renderer(context(), cube4().surface(), empty), std::invalid_argument);
    EXPECT_THROW(Renderer(context(), cube4().surface(), small(Wireframe::Control)), std::invalid_argument)
        << "a control wireframe needs the control faces";
}

// The image side needs no device.
TEST(RenderCamera, FramesEveryCornerOfTheBox) {
    for (float aspect : {0.5f, 1.0f, 16.0f / 9.0f, 3.0f}) {
        const std::array<float, 3> lo{-1, -2, 0.5f}, hi{3, 1, 2};
        const Camera camera = frameBox(lo, hi, aspect);
        for (int corner = 0; corner < 8; ++corner) {
            const float p[3] = {corner & 1 ? hi[0] : lo[0], corner & 2 ? hi[1] : lo[1], corner & 4 ? hi[2] : lo[2]};
            const auto c = clip(camera.viewProjection, p);
            ASSERT_GT(c[3], 0);
            for (int axis = 0; axis < 2; ++axis) {
                EXPECT_LE(std::abs(c[axis] / c[3]), 1.0) << "aspect " << aspect << " corner " << corner;
            }
            EXPECT_GE(c[2] / c[3], 0.0);
            EXPECT_LE(c[2] / c[3], 1.0);
        }
        // Up is up: the box's top projects above its bottom (smaller pixel y).
        const float top[3] = {1, 1, 1.25f}, bottom[3] = {1, -2, 1.25f};
        EXPECT_LT(toPixel(clip(camera.viewProjection, top), 100, 100)[1],
                  toPixel(clip(camera.viewProjection, bottom), 100, 100)[1]);
        EXPECT_GT(camera.eye[2], camera.target[2]) << "in front";
        EXPECT_GT(camera.eye[0], camera.target[0]) << "a bit right";
        EXPECT_GT(camera.eye[1], camera.target[1]) << "a bit above";
    }
}

// lookAt (the viewer's orbit camera): the target lands at the image centre from any eye, and
// frameBox's own eye and target give frameBox's matrices.
TEST(RenderCamera, LookAtCentresTheTargetAndReproducesFrameBox) {
    const std::array<float, 3> lo{-1, -2, 0.5f}, hi{3, 1, 2};
    const Camera framed = frameBox(lo, hi, 1.5f);
    const float radius = 0.5f * std::sqrt(16.0f + 9.0f + 2.25f) * 1.04f;
    const Camera again = lookAt(framed.eye, framed.target, radius, 1.5f);
    for (int i = 0; i < 16; ++i) EXPECT_NEAR(again.viewProjection[i], framed.viewProjection[i], 1e-4f) << i;
    for (const std::array<float, 3> eye : {std::array<float, 3>{5, 1, 2}, {-3, 4, -6}, {1, -5, 0.5f}}) {
        const Camera camera = lookAt(eye, {1, 0, 1}, 2.0f, 1.5f);
        const float target[3] = {1, 0, 1};
        const auto c = clip(camera.viewProjection, target);
        ASSERT_GT(c[3], 0);
        EXPECT_NEAR(c[0] / c[3], 0.0, 1e-5);
        EXPECT_NEAR(c[1] / c[3], 0.0, 1e-5);
        EXPECT_GT(c[2] / c[3], 0.0);
        EXPECT_LT(c[2] / c[3], 1.0);
    }
    EXPECT_THROW(lookAt({1, 1, 1}, {1, 1, 1}, 1.0f, 1.0f), std::invalid_argument) << "eye at the target";
    EXPECT_THROW(lookAt({0, 0, 5}, {0, 0, 0}, 1.0f, 0.0f), std::invalid_argument);
}

TEST(RenderCamera, LooksAlongAnotherDirectionWhenAsked) {
    const std::array<float, 3> lo{-1, -1, -1}, hi{1, 1, 1};
    const Camera camera = frameBox(lo, hi, 1.0f, {-2, 0, 0});
    EXPECT_LT(camera.eye[0], -2.0f) << "on the -x side, outside the box";
    EXPECT_NEAR(camera.eye[1], 0.0f, 1e-5f);
    EXPECT_NEAR(camera.eye[2], 0.0f, 1e-5f);
    for (int corner = 0; corner < 8; ++corner) {
        const float p[3] = {corner & 1 ? 1.0f : -1.0f, corner & 2 ? 1.0f : -1.0f, corner & 4 ? 1.0f : -1.0f};
        const auto c = clip(camera.viewProjection, p);
        ASSERT_GT(c[3], 0);
        EXPECT_LE(std::abs(c[0] / c[3]), 1.0);
        EXPECT_LE(std::abs(c[1] / c[3]), 1.0);
    }
    EXPECT_THROW(frameBox(lo, hi, 1.0f, {0, 1, 0}), std::invalid_argument) << "straight down: no up vector";
    EXPECT_THROW(frameBox(lo, hi, 0.0f), std::invalid_argument);
}

TEST(RenderImage, PngRoundTripsItsPixels) {
    const fs::path dir = fs::temp_directory_path() / ("psub_render_png_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    Image image = filledImage(37, 23, {10, 20, 30, 255});
    for (std::uint32_t y = 0; y < image.height; ++y)
        for (std::uint32_t x = 0; x < image.width; ++x)
            image.setPixel(x, y, {std::uint8_t(x * 7), std::uint8_t(y * 11), std::uint8_t(x ^ y), std::uint8_t(255 - x)});
    const std::string path = (dir / "round.png").string();
    writePng(path, image);
    const Image back = readPng(path);
    EXPECT_EQ(back.width, image.width);
    EXPECT_EQ(back.height, image.height);
    EXPECT_TRUE(back.rgba == image.rgba);
    std::size_t entries = 0;
    for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++entries;
    EXPECT_EQ(entries, 1u) << "no temporary file left";
    fs::remove_all(dir);
}

TEST(RenderImage, PngToABadPathThrowsNamingItAndLeavesNoFile) {
    const fs::path dir = fs::temp_directory_path() / ("psub_render_bad_" + std::to_string(::getpid()));
    fs::create_directories(dir / "taken");
    fs::create_directories(dir / "taken" / "inside");  // a non-empty directory: rename onto it fails
    const Image image = filledImage(4, 4, {1, 2, 3, 255});
    const std::string missing = (dir / "no-such-dir" / "x.png").string();
    try {
        writePng(missing, image);
        ADD_FAILURE() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(missing));
    const std::string taken = (dir / "taken").string();
    try {
        writePng(taken, image);
        ADD_FAILURE() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(taken), std::string::npos) << e.what();
    }
    std::size_t entries = 0;
    for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++entries;
    EXPECT_EQ(entries, 1u) << "only the directory that was there";
    EXPECT_TRUE(fs::is_directory(taken));
    fs::remove_all(dir);
}

TEST(RenderImage, CaptionsAndPanels) {
    Image image = filledImage(120, 40, {255, 255, 255, 255});
    drawText(image, 4, 4, "P-S 4", 2, {0, 0, 0, 255});
    const std::size_t inked = countPixels(image, [](Rgba p) { return p.r == 0; });
    EXPECT_GT(inked, 50u);
    const auto size = textSize("P-S 4", 2);
    EXPECT_GT(size[0], 20);
    EXPECT_GT(size[1], 10);
    drawText(image, 110, 35, "clipped at the edge", 3, {0, 0, 0, 255});  // must not write outside
    const std::vector<Image> panels = {filledImage(50, 30, {255, 0, 0, 255}), filledImage(50, 30, {0, 0, 255, 255})};
    const std::vector<std::string> captions = {"left", "right"};
    const Image figure = panelsWithCaptions(panels, captions, 1);
    EXPECT_EQ(figure.width, 100u);
    EXPECT_GT(figure.height, 30u + 7u);
    EXPECT_TRUE(figure.pixel(10, 10) == (Rgba{255, 0, 0, 255}));
    EXPECT_TRUE(figure.pixel(60, 10) == (Rgba{0, 0, 255, 255}));
    const std::size_t captionInk = countPixels(figure, [](Rgba p) { return p.r < 100 && p.b < 100; });
    EXPECT_GT(captionInk, 20u);
    const std::vector<Image> uneven = {filledImage(50, 30, {}), filledImage(40, 30, {})};
    EXPECT_THROW(panelsWithCaptions(uneven, captions), std::invalid_argument);
}

// psub's exit status. Under the sanitizers its leak check is off: the driver's state above
// would be reported when psub unloads lavapipe.
int runPsub(const std::string& arguments, const std::string& environment = "") {
    test::PsubHow how;
    how.environment = std::string(test::kNoLeakCheck) + " " + environment;
    return test::runPsub(arguments, how).status;
}

class RenderCommand : public test::VulkanCommandTest {};

TEST_F(RenderCommand, WritesAPng) {
    const std::string out = (dir_ / "cube.png").string();
    ASSERT_EQ(runPsub("render " + test::dataPath("cube.obj") + " -o " + out + " --levels 2"), 0);
    const Image image = readPng(out);
    EXPECT_EQ(image.width, 1280u);
    EXPECT_EQ(image.height, 720u);
    EXPECT_GT(notBackground(image, {255, 255, 255, 255}), 1000u);
}

TEST_F(RenderCommand, Figure5RowsShowPSBesideCatmullClarkOnOneCamera) {
    ASSERT_EQ(runPsub("figure5 -o " + dir_.string() + " --panel-size 160x120"), 0);
    for (const char* name : {"figure5_cow.png", "figure5_cube.png"}) {
        const Image row = readPng((dir_ / name).string());
        EXPECT_EQ(row.width, 3u * 160u) << name;
        EXPECT_GT(row.height, 120u) << name;  // the caption band
    }
    // The cube row: input, P-S 4 steps, Catmull-Clark 2 levels, one camera. P-S shrinks the cube
    // far more than Catmull-Clark does (docs/scheme.md, "The paper's claims"): fewer covered pixels.
    const Image cube = readPng((dir_ / "figure5_cube.png").string());
    std::size_t covered[3] = {0, 0, 0};
    for (std::uint32_t y = 0; y < 120; ++y)
        for (std::uint32_t x = 0; x < cube.width; ++x) covered[x / 160] += !(cube.pixel(x, y) == Rgba{255, 255, 255, 255});
    EXPECT_GT(covered[0], covered[2]);
    EXPECT_GT(covered[2], 2 * covered[1]);
    EXPECT_GT(covered[1], 50u);
    EXPECT_EQ(readPng((dir_ / "table1.png").string()).width, 800u);
    EXPECT_EQ(runPsub("figure5 -o " + dir_.string() + " --panel-size 10x10"), 2);
}

TEST_F(RenderCommand, SchemesWireframesAndBackends) {
    const std::string out = (dir_ / "x.png").string();
    const std::string cube = test::dataPath("cube.obj");
    EXPECT_EQ(runPsub("render " + cube + " -o " + out + " --levels 2 --scheme cc --wireframe refined --size 128x96"), 0);
    EXPECT_EQ(readPng(out).width, 128u);
    EXPECT_EQ(runPsub("render " + cube + " -o " + out + " --levels 3 --wireframe control --backend vulkan --size 96x96"), 0);
    EXPECT_EQ(readPng(out).height, 96u);
}

// --form tiled draws the tiled form's own vertex order: its faces, the refined edges over them
// and its textured faces over the same UVs. Spot at 8 steps is two thirds tiled. The pictures
// are the per-level ones up to the float rounding of the positions (a few pixels along edges);
// a face list in the wrong order would scatter triangles over the picture.
// Two pictures the same up to the float rounding of the positions: at most 1 in 255 off on
// average, at most 0.5% of the pixels more than 32 off.
void expectSamePicture(const std::string& first, const std::string& second, const std::string& what) {
    const Image a = readPng(first), b = readPng(second);
    ASSERT_EQ(a.rgba.size(), b.rgba.size()) << what;
    EXPECT_GT(notBackground(a, {255, 255, 255, 255}), a.rgba.size() / 4 / 10) << what;
    std::size_t off = 0;
    double sum = 0;
    for (std::size_t i = 0; i < a.rgba.size(); i += 4)
        for (std::size_t c = 0; c < 3; ++c) {
            const int d = std::abs(int(a.rgba[i + c]) - int(b.rgba[i + c]));
            sum += d;
            off += d > 32;
        }
    EXPECT_LE(sum / double(a.rgba.size() / 4 * 3), 1.0) << what;
    EXPECT_LE(double(off), 0.005 * double(a.rgba.size() / 4)) << what;
}

TEST_F(RenderCommand, TiledFormDrawsThePerLevelPicture) {
    const std::string model = test::dataPath("spot_control_mesh_uv.obj");
    const std::string perLevel = (dir_ / "per-level.png").string(), tiled = (dir_ / "tiled.png").string();
    for (const std::string& extra : {" --texture " + test::dataPath("spot_texture.png"), std::string(" --wireframe refined")}) {
        const std::string common = "render " + model + " --levels 8 --size 200x160" + extra;
        ASSERT_EQ(runPsub(common + " -o " + perLevel), 0) << extra;
        test::PsubHow how;
        how.environment = test::kNoLeakCheck;
        const test::PsubRun run = test::runPsub(common + " --form tiled -o " + tiled, how);
        ASSERT_EQ(run.status, 0) << run.err;
        EXPECT_NE(run.out.find("tiled form"), std::string::npos) << run.out;
        expectSamePicture(perLevel, tiled, extra);
    }
}

// Where the tiles cover the mesh (a 48 x 48 torus at 4 steps), --form tiled draws the
// drawing-only build (no level after B, the faces tile after tile: RefineOptions::canonicalOrder
// false): the per-level picture again, its faces and the refined edges over them (corners
// mixed up would scatter triangles; the picture does not show the faces' orientation, which
// Tiled.TheDrawingOnlyBuildPlacesTheTilesOnLevelB checks).
TEST_F(RenderCommand, TiledFormOfAMeshTheTilesCoverDrawsThePerLevelPicture) {
    const std::string model = (dir_ / "torus.obj").string();
    test::writeTorusObj(model, 48);
    {  // the build `psub render --form tiled` makes: no canonical order, so none of the levels after B
        const test::Loaded loaded = test::load(model);
        RefineOptions options;
        options.levels = 4, options.tiled = true, options.perLevel = false, options.canonicalOrder = false;
        const Refinement r = refine(loaded.mesh, loaded.checked.connectivity, options);
        ASSERT_GT(r.tiled.tileCount(), 0u);
        ASSERT_TRUE(r.tiled.canonical.empty());
    }
    const std::string perLevel = (dir_ / "per-level.png").string(), tiled = (dir_ / "tiled.png").string();
    for (const std::string extra : {"", " --wireframe refined"}) {
        const std::string common = "render " + model + " --levels 4 --size 200x160" + extra;
        ASSERT_EQ(runPsub(common + " -o " + perLevel), 0) << extra;
        ASSERT_EQ(runPsub(common + " --form tiled -o " + tiled), 0) << extra;
        expectSamePicture(perLevel, tiled, extra);
    }
}

TEST_F(RenderCommand, BadInputExits1AndUsageErrorsExit2WithoutAFile) {
    const std::string out = (dir_ / "bad.png").string();
    EXPECT_EQ(runPsub("render " + test::testDataPath("bad/nan_coordinate.obj") + " -o " + out), 1);
    EXPECT_EQ(runPsub("render " + (dir_ / "missing.obj").string() + " -o " + out), 1);
    EXPECT_EQ(runPsub("render " + test::dataPath("cube.obj") + " -o " + (dir_ / "no-dir" / "x.png").string() +
                      " --levels 1 --size 64x64"),
              1);
    EXPECT_EQ(runPsub("render " + test::dataPath("cube.obj") + " -o " + out + " --levels 1",
                      "VK_ICD_FILENAMES=/nonexistent.json"),
              1)
        << "no Vulkan driver";
    EXPECT_EQ(runPsub("render " + test::dataPath("cube.obj") + " -o " + out + " --size 12by7"), 2);
    EXPECT_EQ(runPsub("render " + test::dataPath("cube.obj") + " -o " + out + " --wireframe dots"), 2);
    EXPECT_EQ(runPsub("render " + test::dataPath("cube.obj") + " -o " + out + " --form factorized"), 2);
    EXPECT_EQ(runPsub("render " + test::dataPath("cube.obj")), 2);
    EXPECT_FALSE(fs::exists(out));
}

TEST(RenderCommandHelp, TeachesWithAnExample) {
    const std::string out = (fs::temp_directory_path() / ("psub_render_help_" + std::to_string(::getpid()))).string();
    const int status = std::system((std::string(PSUB_EXE) + " render --help >" + out + " 2>&1").c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
    std::FILE* f = std::fopen(out.c_str(), "r");
    ASSERT_NE(f, nullptr);
    std::string text;
    char buffer[4096];
    for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, f)) > 0;) text.append(buffer, n);
    std::fclose(f);
    std::remove(out.c_str());
    EXPECT_NE(text.find("psub render data/cube.obj -o cube.png"), std::string::npos) << text;
    EXPECT_NE(text.find("--wireframe"), std::string::npos);
}

}  // namespace
}  // namespace psub
