// Round trips through `psub subdivide`: OBJ -> glTF -> OBJ keeps positions, UVs (OBJ's v up
// written as glTF's v down and back) and faces; glTF -> glTF keeps the material and its texture.
// `--scheme cc --levels 0` is the level-0 path that writes a mesh as it is, UVs included.
#include "test_support.h"

#include "psub/animation.h"

#include <gtest/gtest.h>

namespace {

using namespace psub;

// The cube's eight corners and six quads, each quad its own UV island (24 values).
std::string cubeWithIslands() {
    std::ostringstream obj;
    obj << test::cubeObj("1").substr(0, test::cubeObj("1").find("f "));
    const int quads[6][4] = {{1, 3, 4, 2}, {5, 6, 8, 7}, {1, 2, 6, 5}, {2, 4, 8, 6}, {4, 3, 7, 8}, {3, 1, 5, 7}};
    const double corner[4][2] = {{0, 0}, {0.25, 0}, {0.25, 0.375}, {0, 0.375}};
    for (int f = 0; f < 6; ++f)
        for (const auto& c : corner) obj << "vt " << 0.3125 * (f % 3) + c[0] << ' ' << 0.5 * (f / 3) + c[1] << '\n';
    for (int f = 0; f < 6; ++f) {
        obj << 'f';
        for (int k = 0; k < 4; ++k) obj << ' ' << quads[f][k] << '/' << 4 * f + k + 1;
        obj << '\n';
    }
    return obj.str();
}

std::array<double, 3> positionOf(const Mesh& mesh, Index vertex) {
    return {mesh.positions[3 * vertex], mesh.positions[3 * vertex + 1], mesh.positions[3 * vertex + 2]};
}
std::array<double, 2> uvOf(const Mesh& mesh, std::size_t corner) {
    const Index value = mesh.uv.corners[corner];
    return {mesh.uv.values[2 * value], mesh.uv.values[2 * value + 1]};
}

class CliRoundTrip : public ::testing::Test {
protected:
    std::string file(const std::string& name) const { return (scratch_ / name).string(); }
    void subdivide(const std::string& arguments) {
        const test::PsubRun run = test::runPsub(scratch_, "subdivide " + arguments);
        ASSERT_EQ(run.status, 0) << arguments << "\n" << run.err;
    }
    test::ScratchDir scratch_;
};

// OBJ -> glTF (P-S, 0 steps: the quads, two triangles each) -> OBJ (the level-0 path): the
// triangles [a b c], [a c d] of every quad [a b c d], with its positions and its island's UVs.
TEST_F(CliRoundTrip, ObjToGltfToObjKeepsPositionsUvsAndFaces) {
    test::writeFile(file("cube.obj"), cubeWithIslands());
    subdivide(test::quoted(file("cube.obj")) + " -o " + test::quoted(file("cube.glb")) + " --levels 0");
    subdivide(test::quoted(file("cube.glb")) + " --levels 0 --scheme cc -o " + test::quoted(file("back.obj")));
    const Mesh input = readObj(file("cube.obj"));
    const GltfAsset gltf = readGltf(file("cube.glb"));
    const Mesh back = readObj(file("back.obj"));
    ASSERT_EQ(back.faces.faceCount(), 2 * input.faces.faceCount());
    EXPECT_EQ(back.faces.vertexCount, input.faces.vertexCount);  // welded again
    ASSERT_FALSE(back.uv.empty());
    ASSERT_EQ(gltf.mesh.uv.corners.size(), back.uv.corners.size());
    for (Index f = 0; f < input.faces.faceCount(); ++f) {
        const Index first = input.faces.offsets[f];
        const Index corners[6] = {first, first + 1, first + 2, first, first + 2, first + 3};
        for (std::size_t k = 0; k < 6; ++k) {
            const std::size_t corner = 6 * std::size_t(f) + k;
            EXPECT_EQ(back.faces.offsets[2 * f + k / 3] + k % 3, corner);
            EXPECT_EQ(positionOf(back, back.faces.verts[corner]), positionOf(input, input.faces.verts[corners[k]]));
            const auto uv = uvOf(input, corners[k]);
            const auto written = uvOf(gltf.mesh, corner), read = uvOf(back, corner);
            EXPECT_FLOAT_EQ(float(written[0]), float(uv[0])) << "face " << f;
            EXPECT_FLOAT_EQ(float(written[1]), float(1 - uv[1])) << "face " << f << ": glTF's v runs down";
            EXPECT_FLOAT_EQ(float(read[0]), float(uv[0])) << "face " << f;
            EXPECT_FLOAT_EQ(float(read[1]), float(uv[1])) << "face " << f;
        }
    }
}

// glTF -> glTF: the refined CesiumMan keeps its material, factor, sampler and JPEG bytes; at
// level 0 (--scheme cc) its UVs come back corner for corner.
TEST_F(CliRoundTrip, GltfToGltfKeepsMaterialAndTexture) {
    const std::string cesium = test::dataPath("CesiumMan.glb");
    subdivide(test::quoted(cesium) + " -o " + test::quoted(file("man1.glb")) + " --levels 1");
    subdivide(test::quoted(cesium) + " -o " + test::quoted(file("man0.gltf")) + " --levels 0 --scheme cc");
    const GltfAsset input = readGltf(cesium);
    ASSERT_TRUE(input.material && input.material->baseColorTexture);
    for (const std::string name : {"man1.glb", "man0.gltf"}) {
        const GltfAsset output = readGltf(file(name));
        ASSERT_TRUE(output.material && output.material->baseColorTexture) << name;
        EXPECT_EQ(output.material->baseColorFactor, input.material->baseColorFactor) << name;
        EXPECT_EQ(output.material->baseColorTexture->mimeType, "image/jpeg") << name;
        EXPECT_EQ(output.material->baseColorTexture->bytes, input.material->baseColorTexture->bytes) << name;
        EXPECT_EQ(output.material->sampler.wrapS, input.material->sampler.wrapS) << name;
        EXPECT_FALSE(output.mesh.uv.empty()) << name;
    }
    // Level 0: the static pose's positions (psub subdivide poses the skin) and the input's UVs.
    const GltfAsset level0 = readGltf(file("man0.gltf"));
    GltfPlayer player(input);
    std::vector<float> posed(3 * player.vertexCount());
    player.staticPose(posed);
    ASSERT_EQ(level0.mesh.uv.corners.size(), input.mesh.uv.corners.size());
    for (std::size_t c = 0; c < input.mesh.uv.corners.size(); ++c) {
        ASSERT_EQ(uvOf(level0.mesh, c), uvOf(input.mesh, c)) << "corner " << c;
        const Index vertex = input.mesh.faces.verts[c];
        const std::array<double, 3> expected{posed[3 * vertex], posed[3 * vertex + 1], posed[3 * vertex + 2]};
        ASSERT_EQ(positionOf(level0.mesh, level0.mesh.faces.verts[c]), expected) << "corner " << c;
    }
}

}  // namespace
