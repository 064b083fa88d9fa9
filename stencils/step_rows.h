// Internal to stencils/: the row builder of one step, shared by positions and face-varying
// channels (docs/face-varying.md).
#pragma once

#include "psub/rules.h"
#include "psub/tables.h"
#include "psub/topology.h"

#include <cstdint>
#include <span>

namespace psub {

// Appends the rows of one step over `faces` to `table` (a new StencilLevel). `paired` retains
// every old vertex; each face f with seamFaces[f] != 0 (when not empty) gets the midpoint of
// its first two corners (a BoundaryEdge row) instead of its average. `inputCorners`: per
// input vertex, whether it is an input corner (psub/rules.h's inputCorners()). With `keep`
// (one flag per child vertex) only the rows of the child vertices it flags are made.
void appendStepRows(PerLevelTable& table, const Faces& faces, const Connectivity& connectivity, bool paired,
                    bool splitBoundary, std::span<const std::uint8_t> seamFaces, Rules rules,
                    std::span<const char> inputCorners, std::span<const std::uint8_t> keep = {});

}  // namespace psub
