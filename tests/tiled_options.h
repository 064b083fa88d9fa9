// refine()'s options for the tiled form, shared by the tiled tests (CPU and Vulkan).
#pragma once

#include "psub/stencils.h"

namespace psub::test {

inline RefineOptions tiledOptions(int levels, Boundary boundary = Boundary::Paper, Rules rules = Rules::Paper,
                                  TileSides sides = TileSides::Cheapest) {
    RefineOptions options;
    options.levels = levels;
    options.boundary = boundary;
    options.rules = rules;
    options.tiled = true;
    options.tileSides = sides;
    return options;
}

}  // namespace psub::test
