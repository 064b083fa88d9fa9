// psub_texture_draw: the renderer's per-frame cost, flat against textured, on a generated
// grid of N x N quads (UVs per corner, a seam down the middle) under a 1024x1024 texture.
// Prints the median upload, render and readback milliseconds of each. A benchmark, not a
// test: see bench/README.md ("Textured drawing").
//   psub_texture_draw [N=512] [FRAMES=20] [SIZE=1280x720]
#include "psub/render.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
    using namespace psub;
    const std::uint32_t n = argc > 1 ? std::uint32_t(std::atoi(argv[1])) : 512;
    const int frames = argc > 2 ? std::atoi(argv[2]) : 20;
    RenderOptions ro;
    if (argc > 3 && std::sscanf(argv[3], "%ux%u", &ro.width, &ro.height) != 2) return 2;
    if (n < 2 || frames < 1) return 2;
    const std::uint32_t side = n + 1;
    std::vector<float> positions, normals, uv;
    for (std::uint32_t y = 0; y < side; ++y)
        for (std::uint32_t x = 0; x < side; ++x) {
            positions.insert(positions.end(), {float(x) / float(n) * 2 - 1, float(y) / float(n) * 2 - 1, 0});
            normals.insert(normals.end(), {0, 0, 1});
        }
    // UV values: one per vertex, plus a second copy of the middle column (the seam).
    for (std::uint32_t y = 0; y < side; ++y)
        for (std::uint32_t x = 0; x < side; ++x) uv.insert(uv.end(), {float(x) / float(n), float(y) / float(n)});
    const std::uint32_t seamValues = side * side;
    for (std::uint32_t y = 0; y < side; ++y) uv.insert(uv.end(), {0.5f + 0.25f, float(y) / float(n)});
    std::vector<std::uint32_t> offsets{0}, verts, values;
    for (std::uint32_t y = 0; y < n; ++y)
        for (std::uint32_t x = 0; x < n; ++x) {
            const std::uint32_t corners[4] = {y * side + x, y * side + x + 1, (y + 1) * side + x + 1, (y + 1) * side + x};
            for (std::uint32_t c : corners) {
                verts.push_back(c);
                const bool seam = c % side == n / 2 && x >= n / 2;  // right of the seam: its own values
                values.push_back(seam ? seamValues + c / side : c);
            }
            offsets.push_back(std::uint32_t(verts.size()));
        }
    Image texture = filledImage(1024, 1024, {200, 120, 60, 255});
    for (std::uint32_t y = 0; y < 1024; ++y)
        for (std::uint32_t x = 0; x < 1024; ++x)
            if ((x / 64 + y / 64) % 2) texture.setPixel(x, y, {40, 90, 200, 255});
    VulkanContext context;
    const Polygons surface{std::uint32_t(side * side), offsets, verts};
    const Camera camera = frameBox({-1, -1, 0}, {1, 1, 0}, float(ro.width) / float(ro.height), {0.3f, 0.4f, 1});
    std::printf("%u quads, %ux%u, %d frames, %s (median ms)\n", n * n, ro.width, ro.height, frames,
                context.deviceName().c_str());
    for (bool textured : {false, true}) {
        SurfaceTexture t;
        if (textured) t = SurfaceTexture{offsets, verts, values, uv, &texture};
        Renderer renderer(context, surface, ro, {}, t);
        Image out;
        renderer.draw(positions, normals, camera, out);  // warm-up: shader compilation
        std::vector<double> upload, render, readback;
        for (int f = 0; f < frames; ++f) {
            renderer.draw(positions, normals, camera, out);
            upload.push_back(renderer.lastTimes().uploadMs);
            render.push_back(renderer.lastTimes().renderMs);
            readback.push_back(renderer.lastTimes().readbackMs);
        }
        std::printf("%-9s upload %7.3f  render %8.3f  readback %7.3f\n", textured ? "textured" : "flat",
                    median(upload), median(render), median(readback));
    }
    return 0;
}
