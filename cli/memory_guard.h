// The memory guard of subdivide and stats (memory_guard.cpp).
#pragma once

#include "psub/topology.h"

#include <cstdint>

namespace psub::cli {

// Throws InputError when `--levels levels` would not fit in `limit` bytes (0: 3/4 of the
// physical memory) or in 32-bit indices, naming the estimate and the most levels that fit. A
// level is `stepsPerLevel` topological steps (2 for Catmull-Clark, which quadruples the
// faces), after `extraSteps` (the paired method).
void guardMemory(const Mesh& mesh, const Counts& input, int levels, int stepsPerLevel, int extraSteps,
                 std::uint64_t limit, Boundary boundary = Boundary::Paper);

}  // namespace psub::cli
