// Small helpers shared by the unit tests: loading bundled models, building meshes in memory.
#pragma once

#include "psub/topology.h"

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>
#include <vector>

namespace psub::test {

// True in AddressSanitizer builds (GCC's and clang's spellings).
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

inline std::string dataPath(const std::string& name) { return std::string(PSUB_DATA) + "/" + name; }
inline std::string testDataPath(const std::string& name) { return std::string(PSUB_TEST_DATA) + "/" + name; }

// Every model the tests refine: bundled ones and the test set (valid meshes only).
inline std::vector<std::string> allValidModels() {
    std::vector<std::string> models = {dataPath("cube.obj"), dataPath("grid4x4.obj"),
                                       dataPath("spot_control_mesh.obj"), dataPath("cow.obj")};
    for (const char* name : {"triangle.obj", "tetrahedron.obj", "suzanne.obj", "bowtie.obj",
                             "mechpart.obj", "double-torus.obj"})
        models.push_back(testDataPath(name));
    for (const char* name :
         {"catmark_cube", "catmark_torus", "catmark_toroidal_tet", "catmark_lefthanded",
          "catmark_tent", "catmark_edgecorner", "catmark_xord_boundary", "catmark_pawn",
          "catmark_pyramid", "catmark_smoothtris0", "catmark_pole64", "catmark_nonquads",
          "catmark_val2_interior", "catmark_nonman_verts"})
        models.push_back(testDataPath(std::string("osd-shapes/") + name + ".obj"));
    return models;
}

struct Loaded {
    Mesh mesh;
    CheckedMesh checked;
};

inline Loaded load(const std::string& path) {
    Loaded loaded{readObj(path), {}};
    loaded.checked = checkMesh(loaded.mesh);
    return loaded;
}

// The message of the InputError that `action` throws; a test failure when it throws none.
template <class Action>
std::string inputErrorOf(Action&& action) {
    try {
        action();
    } catch (const InputError& error) {
        return error.what();
    }
    ADD_FAILURE() << "expected an InputError";
    return "(no error)";
}

// A mesh from literal positions and faces (0-based corners).
inline Mesh makeMesh(std::vector<double> positions,
                     std::initializer_list<std::initializer_list<Index>> faces) {
    Mesh mesh;
    mesh.positions = std::move(positions);
    mesh.faces.vertexCount = Index(mesh.positions.size() / 3);
    for (auto face : faces) mesh.faces.addFace(std::vector<Index>(face));
    return mesh;
}

inline Hierarchy refine(const Loaded& loaded, int steps, Preprocess mode = Preprocess::Auto,
                        Boundary boundary = Boundary::Paper) {
    const bool preprocess = needsPreprocessing(loaded.mesh.faces, loaded.checked.connectivity, mode);
    return refineTopology(loaded.mesh.faces, loaded.checked.connectivity, preprocess, steps, {}, boundary);
}

// Models with a boundary and no non-manifold vertex (where --boundary smooth has work to do
// and OpenSubdiv's boundary rules apply unchanged).
inline std::vector<std::string> manifoldModelsWithBoundary() {
    std::vector<std::string> models;
    for (const std::string& path : allValidModels()) {
        const Loaded loaded = load(path);
        bool nonManifold = false;
        for (VertexKind kind : loaded.checked.connectivity.kind) nonManifold = nonManifold || kind == VertexKind::NonManifold;
        if (loaded.checked.connectivity.boundaryEdgeCount > 0 && !nonManifold) models.push_back(path);
    }
    return models;
}

}  // namespace psub::test
