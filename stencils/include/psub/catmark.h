// psub/catmark.h: Catmull-Clark refinement through OpenSubdiv (Far::TopologyRefiner +
// PrimvarRefiner, SCHEME_CATMARK, VTX_BOUNDARY_EDGE_ONLY, no creases), the reference that
// P-S is compared with. Vertex and face order are OpenSubdiv's.
#pragma once

#include "psub/topology.h"

#include <span>
#include <vector>

namespace psub {

struct CatmarkLevel {
    Faces faces;
    std::vector<double> positions;  // xyz; empty when only counts were asked for
    Counts counts;
};

// Uniform Catmull-Clark levels 0..levels of a validated mesh. With `withPositions` false
// only topology is refined (for counts).
std::vector<CatmarkLevel> refineCatmark(const Faces& faces, std::span<const double> positions,
                                        int levels, bool withPositions = true);

}  // namespace psub
