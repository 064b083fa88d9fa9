// The CPU per-frame loop through the installed package: both table forms, every frame checked
// against the rule path. Exit 1 on any mismatch or error.
//
//   cpu_consumer MODEL.obj LEVELS FRAMES
#include "frame_check.h"

#include "psub/evaluator.h"

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: cpu_consumer MODEL.obj LEVELS FRAMES\n");
        return 2;
    }
    try {
        const consumer::Model m = consumer::load(argv[1], std::stoi(argv[2]));
        const psub::Refinement& r = m.refinement;
        psub::CpuEvaluator<float> perLevel(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel);
        psub::CpuEvaluator<float> factorized(r.perLevel, r.factorized, r.surface, psub::TableForm::Factorized);
        std::vector<float> refined(3 * std::size_t(perLevel.refinedCount())), normals(refined.size());
        const int frames = std::stoi(argv[3]);
        bool ok = true;
        for (int frame = 0; frame < frames; ++frame) {
            const std::vector<double> control = consumer::deformed(m.mesh, frame);
            const std::vector<float> control32 = consumer::toFloat(control);
            perLevel.evaluate(control32, refined);
            ok = consumer::matchesRules("per-level", frame, m, control, refined, 1e-5) && ok;
            perLevel.normals(refined, normals);
            factorized.evaluate(control32, refined);
            ok = consumer::matchesRules("factorized", frame, m, control, refined, 1e-5) && ok;
        }
        std::printf("cpu_consumer: %s, %u -> %u vertices, %d frames: %s\n", argv[1], perLevel.controlCount(),
                    perLevel.refinedCount(), frames, ok ? "match the rule path" : "MISMATCH");
        return ok ? 0 : 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "cpu_consumer: error: %s\n", e.what());
        return 1;
    }
}
