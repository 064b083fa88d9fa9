// libFuzzer target: whatever bytes arrive are loaded as a glTF file (through a temporary file,
// readGltf's interface); a file that loads is checked as a mesh, every clip is posed at a
// few times, and its cage, UVs (TEXCOORD_0) and material are written back with formatGltf. Only InputError may come out; the poses must stay finite where the file's
// numbers are (readGltf rejects non-finite ones).
#include "psub/animation.h"

#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // .glb or .gltf: told apart by content. In /dev/shm (memory) where there is one: on a disk,
    // truncating the file for every input waits for writeback and discards (the fuzzer spent
    // most of its time blocked in ext4 there, about 0.2 CPU).
    static const std::string path = std::string(access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp") +
                                    "/psub-fuzz-gltf-" + std::to_string(::getpid()) + ".gltf";
    if (std::FILE* file = std::fopen(path.c_str(), "wb")) {
        if (size) std::fwrite(data, 1, size, file);
        std::fclose(file);
    } else {
        return 0;
    }
    try {
        const psub::GltfAsset asset = psub::readGltf(path);
        if (asset.mesh.faces.verts.size() > 100000) return 0;  // keep each input fast
        psub::checkMesh(asset.mesh);
        psub::GltfPlayer player(asset);
        std::vector<float> pose(3 * player.vertexCount());
        player.staticPose(pose);
        for (std::size_t clip = 0; clip < player.clipCount(); ++clip)
            for (double t : {0.0, 0.37, 1.0, 12.5}) player.pose(clip, t, pose);
        const psub::Mesh& mesh = asset.mesh;
        if (!mesh.uv.empty() && mesh.uv.corners.size() != mesh.faces.verts.size()) std::abort();
        for (psub::Index value : mesh.uv.corners)
            if (value >= mesh.uv.valueCount()) std::abort();
        const std::vector<double> normals(mesh.positions.size(), 0.0);
        const psub::GltfSurface surface{mesh.positions, normals, mesh.faces.offsets, mesh.faces.verts,
                                        mesh.uv.corners, mesh.uv.values};
        psub::formatGltf(surface, asset.material ? &*asset.material : nullptr, true, "fuzz");
    } catch (const psub::InputError&) {
    }
    return 0;
}
