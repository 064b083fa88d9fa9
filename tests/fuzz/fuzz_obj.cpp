// libFuzzer target: any bytes through the OBJ reader and the mesh checks. Bad input must be
// an InputError, never a crash, a hang or a leak.
#include "psub/topology.h"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::vector<std::string> warnings;
    try {
        const psub::Mesh mesh =
            psub::parseObj(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.obj", &warnings);
        const psub::CheckedMesh checked = psub::checkMesh(mesh);
        (void)psub::formatObj(mesh.faces, mesh.positions);
        (void)psub::classifyVertices(checked.connectivity);
    } catch (const psub::InputError&) {
    }
    return 0;
}
