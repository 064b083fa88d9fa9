// Internal to topology/: the part of connectivity building shared by the generic builder and
// the direct construction of a refined level.
#pragma once

#include "psub/topology.h"

#include <omp.h>

#include <cstdint>
#include <vector>

namespace psub {

// Long loops of the topological step run in pieces on the OpenMP threads, each piece a range
// of [0, count) that knows where its output starts from counts taken over the pieces before it
// (so the arrays are the same on any thread count). Below topologyPieceMinimum() items (2^21 by
// default), one piece: after a parallel region OpenMP's idle threads spin a while, which slowed
// the one-thread work that follows on this 2-vCPU VM (the 262k-face torus's tiled table 11 ->
// 15 ms with pieces from 2^18 items, which saved it under 1 ms; with OMP_WAIT_POLICY=passive it
// was 11 again).
inline int piecesFor(Index count) { return count < topologyPieceMinimum() ? 1 : omp_get_max_threads(); }
inline Index pieceBegin(Index count, int pieces, int p) {
    return Index(std::uint64_t(count) * std::uint64_t(p) / std::uint64_t(pieces));
}

// Given faces and c.faceOf, c.next and c.twin: numbers the edges (first appearance), builds
// the outgoing half-edge rows (ascending) and the valences. Leaves c.kind alone.
void completeConnectivity(const Faces& faces, Connectivity& c);

}  // namespace psub
