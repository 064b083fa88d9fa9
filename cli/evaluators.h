// The CLI's one choice of backend: makeEvaluator turns --backend into an Evaluator (the
// contract of psub/evaluate.h); nothing after it branches on the backend.
#pragma once

#include "commands.h"
#include "psub/evaluate.h"
#if PSUB_HAVE_VULKAN
#include "psub/vulkan_evaluator.h"
#endif

#include <memory>
#include <stdexcept>

namespace psub {
class VulkanContext;
}

namespace psub::cli {

// Backend::Vulkan runs on `context` (a VulkanContext the caller created, which must outlive the
// evaluator) or, when it is null, on a context of the evaluator's own; Backend::Cpu ignores it.
// Throws VulkanError (a std::runtime_error) when no Vulkan device is usable, and
// std::runtime_error for Vulkan in a psub built without it.
inline std::unique_ptr<Evaluator> makeEvaluator(Backend backend, const EvaluatorTables& tables, TableForm form,
                                                [[maybe_unused]] VulkanContext* context) {
    if (backend != Backend::Vulkan) return makeCpuEvaluator(tables, form);
#if PSUB_HAVE_VULKAN
    return context ? makeVulkanEvaluator(*context, tables, form) : makeVulkanEvaluator(tables, form);
#else
    throw std::runtime_error("this psub was built without Vulkan (PSUB_BUILD_VULKAN=OFF)");
#endif
}

}  // namespace psub::cli
