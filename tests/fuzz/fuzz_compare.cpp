// libFuzzer target: psub compare's geometry on whatever mesh parses, extreme coordinates
// included. Within the double range policy (checkCoordinateRange) the comparison must give
// finite measures; beyond it, the distance search must refuse (std::invalid_argument) or
// answer, never crash, hang or read out of bounds.
#include "psub/analysis.h"
#include "psub/catmark.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        const psub::Mesh mesh = psub::parseObj(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.obj");
        if (mesh.faces.verts.size() > 2000 || mesh.faces.faceCount() == 0) return 0;  // keep each input fast
        const psub::CheckedMesh checked = psub::checkMesh(mesh);
        if (psub::catmarkProblem(mesh)) return 0;
        try {
            psub::checkCoordinateRange(mesh, psub::Precision::Double);
        } catch (const psub::InputError&) {
            try {  // beyond the policy: the grid itself on the raw coordinates
                (void)psub::surfaceDistances(mesh.faces, mesh.positions, mesh.faces, mesh.positions, 1);
            } catch (const std::invalid_argument&) {
            }
            return 0;
        }
        const psub::Fidelity f = psub::compareWithCatmark(mesh, checked.connectivity, 2, psub::Rules::Paper, 1);
        const double values[] = {f.ps.volume, f.ps.area, f.cc.volume, f.cc.area, f.hausdorff(), f.meanDistance()};
        for (double v : values)
            if (!std::isfinite(v)) std::abort();
    } catch (const psub::InputError&) {
    }
    return 0;
}
