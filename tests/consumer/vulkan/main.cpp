// The per-frame loop through the installed package with the Vulkan evaluator (validation layer
// on) beside the CPU one, every frame checked against the rule path. Exit 1 on any mismatch,
// validation message or error; 77 (a skip) when there is no device and PSUB_ALLOW_NO_VULKAN=1.
//
//   vulkan_consumer MODEL.obj LEVELS FRAMES
#include "frame_check.h"

#include "psub/evaluator.h"
#include "psub/vulkan_evaluator.h"

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <vector>

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: vulkan_consumer MODEL.obj LEVELS FRAMES\n");
        return 2;
    }
    try {
        const consumer::Model m = consumer::load(argv[1], std::stoi(argv[2]));
        const psub::Refinement& r = m.refinement;
        psub::VulkanOptions options;
        options.validation = psub::Validation::On;
        std::unique_ptr<psub::VulkanContext> context;
        try {
            context = std::make_unique<psub::VulkanContext>(options);
        } catch (const psub::VulkanError& e) {
            const char* allow = std::getenv("PSUB_ALLOW_NO_VULKAN");
            std::fprintf(stderr, "vulkan_consumer: no Vulkan device: %s\n", e.what());
            return allow && std::string(allow) == "1" ? 77 : 1;
        }
        psub::CpuEvaluator<float> cpu(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel);
        bool ok = true;
        for (psub::TableForm form : {psub::TableForm::PerLevel, psub::TableForm::Factorized}) {
            psub::VulkanEvaluator gpu(*context, r.perLevel, r.factorized, r.surface, form);
            std::vector<float> refined(3 * std::size_t(gpu.refinedCount())), normals(refined.size());
            std::vector<float> cpuRefined(refined.size());
            const int frames = std::stoi(argv[3]);
            for (int frame = 0; frame < frames; ++frame) {
                const std::vector<double> control = consumer::deformed(m.mesh, frame);
                const std::vector<float> control32 = consumer::toFloat(control);
                gpu.evaluate(control32, refined, normals);
                ok = consumer::matchesRules("vulkan", frame, m, control, refined, 1e-5) && ok;
                cpu.evaluate(control32, cpuRefined);
                ok = consumer::matchesRules("cpu", frame, m, control, cpuRefined, 1e-5) && ok;
            }
        }
        if (context->validationMessageCount() != 0) {
            std::fprintf(stderr, "vulkan_consumer: validation messages; the last: %s\n",
                         context->lastValidationMessage().c_str());
            ok = false;
        }
        std::printf("vulkan_consumer: %s on %s, %u -> %u vertices: %s\n", argv[1], context->deviceName().c_str(),
                    cpu.controlCount(), cpu.refinedCount(), ok ? "match the rule path" : "MISMATCH");
        return ok ? 0 : 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "vulkan_consumer: error: %s\n", e.what());
        return 1;
    }
}
