// The per-frame loop in a few lines: refine a mesh once, then refine animated control points
// every frame (positions and normals) with no allocation inside the loop.
//
//   psub_animate [MESH.obj] [LEVELS] [FRAMES]
#include "psub/evaluate.h"
#include "psub/stencils.h"
#if PSUB_HAVE_VULKAN
#include "psub/vulkan_evaluator.h"
#endif

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

int main(int argc, char** argv) {
    const std::string path = argc > 1 ? argv[1] : PSUB_DATA_DIR "/spot_control_mesh.obj";
    const int levels = argc > 2 ? std::stoi(argv[2]) : 4;
    const int frames = argc > 3 ? std::stoi(argv[3]) : 60;
    try {
        // Once: read, check, refine the topology, build the tables, make an evaluator.
        const psub::Mesh mesh = psub::readObj(path);
        const psub::CheckedMesh checked = psub::checkMesh(mesh);
        const psub::Refinement refinement = psub::refine(mesh, checked.connectivity, {levels, psub::Preprocess::Auto, false, {}});
        // The backend: the one line to change. On a Vulkan device (link psub::vulkan):
        //   psub::makeVulkanEvaluator(psub::tablesOf(refinement), psub::TableForm::PerLevel)
        const std::unique_ptr<psub::Evaluator> evaluator =
            psub::makeCpuEvaluator(psub::tablesOf(refinement), psub::TableForm::PerLevel);
        std::vector<float> control(mesh.positions.size());
        std::vector<float> positions(3 * std::size_t(evaluator->refinedCount())), normals(positions.size());

        // Every frame: new control points in, refined positions and normals out.
        double totalMs = 0;
        for (int frame = 0; frame < frames; ++frame) {
            for (std::size_t v = 0; v < control.size() / 3; ++v) {
                const double* p = &mesh.positions[3 * v];
                control[3 * v + 0] = float(p[0]);
                control[3 * v + 1] = float(p[1] + 0.05 * std::sin(4 * p[0] + 0.2 * frame));
                control[3 * v + 2] = float(p[2]);
            }
            const auto start = std::chrono::steady_clock::now();
            evaluator->evaluate(control, positions, normals);
            totalMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
        }
        std::printf("%s: %u control points -> %u refined vertices, %zu faces; %d frames, %.3f ms per "
                    "frame (evaluate + normals, %s)\n",
                    path.c_str(), evaluator->controlCount(), evaluator->refinedCount(),
                    evaluator->surface().faceOffsets.size() - 1, frames, totalMs / frames, evaluator->device().c_str());
        std::printf("first refined vertex (%.4f, %.4f, %.4f), normal (%.3f, %.3f, %.3f)\n", positions[0],
                    positions[1], positions[2], normals[0], normals[1], normals[2]);
    } catch (const psub::InputError& e) {
        std::fprintf(stderr, "psub_animate: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
