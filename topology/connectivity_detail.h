// Internal to topology/: the part of connectivity building shared by the generic builder and
// the direct construction of a refined level.
#pragma once

#include "psub/topology.h"

namespace psub {

// Given faces and c.faceOf, c.next and c.twin: numbers the edges (first appearance), builds
// the outgoing half-edge rows (ascending) and the valences. Leaves c.kind alone.
void completeConnectivity(const Faces& faces, Connectivity& c);

}  // namespace psub
