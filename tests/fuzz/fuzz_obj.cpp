// libFuzzer target: any bytes through the OBJ reader and the mesh checks, and, for a mesh with
// texture coordinates (vt, f v/vt), one refinement of the face-varying channel and its OBJ
// text. Bad input must be an InputError, never a crash, a hang or a leak.
#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "psub/topology.h"

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::vector<std::string> warnings;
    try {
        const psub::Mesh mesh =
            psub::parseObj(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.obj", &warnings);
        const psub::CheckedMesh checked = psub::checkMesh(mesh);
        (void)psub::formatObj(mesh.faces, mesh.positions);
        (void)psub::classifyVertices(checked.connectivity);
        if (!mesh.uv.empty() && mesh.faces.verts.size() <= 4096) {
            psub::RefineOptions options;
            options.levels = 2;
            options.uvLinear = size % 2 == 0 ? psub::UvLinear::Boundaries : psub::UvLinear::All;
            const psub::Refinement r = psub::refine(mesh, checked.connectivity, options);
            std::vector<double> uv(std::size_t(r.uv.width) * r.uv.valueCount());
            psub::evaluateFaceVarying<double>(r.uv, mesh.uv.values, uv);
            (void)psub::formatObjWithUv(mesh.positions, uv, r.uv.width, r.uv.faceOffsets, r.uv.faceVerts, r.uv.faceValues);
        }
    } catch (const psub::InputError&) {
    }
    return 0;
}
