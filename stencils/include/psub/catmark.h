// psub/catmark.h: Catmull-Clark refinement through OpenSubdiv (Far::TopologyRefiner +
// PrimvarRefiner, SCHEME_CATMARK, VTX_BOUNDARY_EDGE_ONLY, no creases), the reference that
// P-S is compared with. Vertex and face order are OpenSubdiv's.
#pragma once

#include "psub/topology.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace psub {

struct CatmarkLevel {
    Faces faces;
    std::vector<double> positions;  // xyz; empty when only counts were asked for
    Counts counts;
};

// Why OpenSubdiv cannot refine `mesh`, naming the file, line and element ("FILE:LINE: face 7:
// 100000 corners, beyond OpenSubdiv's limit of 65534"), or nullopt. Commands that only compare
// with Catmull-Clark then go on without it.
std::optional<std::string> catmarkProblem(const Mesh& mesh);

// Uniform Catmull-Clark levels 0..levels of a validated mesh. With `withPositions` false
// only topology is refined (for counts). When OpenSubdiv refuses the mesh, InputError carries
// its reason (captured from Far's error callback; nothing is printed).
std::vector<CatmarkLevel> refineCatmark(const Faces& faces, std::span<const double> positions,
                                        int levels, bool withPositions = true);

// OpenSubdiv's Catmull-Clark for playback: a stencil table from the control points straight
// to level `levels` (Far::StencilTableFactory, float weights), built once; evaluate() runs it
// and allocates nothing. The finest level's faces and vertex order are refineCatmark's.
class CatmarkStencils {
public:
    CatmarkStencils(const Faces& faces, int levels);  // a validated mesh; InputError otherwise
    ~CatmarkStencils();
    CatmarkStencils(const CatmarkStencils&) = delete;
    CatmarkStencils& operator=(const CatmarkStencils&) = delete;

    const Faces& finestFaces() const;
    std::uint32_t refinedCount() const;
    // control: 3 floats per control vertex; refined: 3 * refinedCount() floats.
    void evaluate(std::span<const float> control, std::span<float> refined) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace psub
