// Class 1 of the hostile inputs: what crashed psub. Huge finite coordinates reaching compare's
// distance search, and glTF JSON nested thousands of levels deep.
#include "test_support.h"

#include "psub/analysis.h"
#include "psub/animation.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace psub::test {
namespace {

using HostileCrash = HostileTest;

TEST_F(HostileCrash, CompareRefusesACubeScaledBeyondTheDoubleLimit) {
    write("big.obj", cubeObj("1e155"));
    refused("compare big.obj --levels 2", 1, {"big.obj:1: vertex 1", "coordinate x = -1e+155", "outside"});
}

TEST_F(HostileCrash, CompareRefusesAllVerticesAt1e200) {
    std::string text;
    for (int v = 0; v < 8; ++v) text += "v 1e200 1e200 1e200\n";
    write("same.obj", text + "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 2 4 8 6\nf 4 3 7 8\nf 3 1 5 7\n");
    refused("compare same.obj --levels 2", 1, {"same.obj:1: vertex 1", "1e+200", "outside"});
}

TEST_F(HostileCrash, CompareJustInsideTheDoubleLimitMeasuresFiniteNumbers) {
    write("edge.obj", cubeObj("1e60"));
    const Run run = psub("compare edge.obj --levels 2 --json");
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_FALSE(contains(run.out, "null")) << run.out;  // jsonNumber writes null for inf and NaN
    EXPECT_TRUE(contains(run.out, "\"hausdorff\"")) << run.out;
}

// The library at the source: the distance search refuses coordinates whose squares overflow and
// never turns a NaN into an index or a distance.
TEST(HostileCrashLibrary, DistanceGridRefusesOverflowingOrNonFiniteCoordinates) {
    Faces triangle;
    triangle.vertexCount = 3;
    triangle.addFace(std::vector<Index>{0, 1, 2});
    const std::vector<double> ok = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    for (double bad : {1e200, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
        SCOPED_TRACE(bad);
        const std::vector<double> huge = {0, 0, 0, bad, 0, 0, 0, bad, 0};
        EXPECT_THROW(surfaceDistances(triangle, ok, triangle, huge, 2), std::invalid_argument);
    }
    const std::vector<double> distances = surfaceDistances(triangle, ok, triangle, ok, 2);
    for (double d : distances) EXPECT_NEAR(d, 0.0, 1e-12);
}

TEST(HostileCrashLibrary, DistanceToANaNPointIsNotAnIndexOutOfTheGrid) {
    Faces triangle;
    triangle.vertexCount = 3;
    triangle.addFace(std::vector<Index>{0, 1, 2});
    const std::vector<double> target = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const std::vector<double> from = {nan, 0, 0, 1, 0, 0, 0, 1, 0};
    const std::vector<double> distances = surfaceDistances(triangle, from, triangle, target, 2);
    // One triangle sampled on its barycentric grid of m = 2: (m + 1)(m + 2) / 2 = 6 points.
    // Every point is w * NaN + ... (0 * NaN is NaN too), so every distance is NaN: a point
    // without coordinates has no nearest triangle, and no crash.
    ASSERT_EQ(distances.size(), 6u);
    for (double d : distances) EXPECT_TRUE(std::isnan(d)) << d;
}

std::string nested(std::size_t depth) {
    return std::string(depth, '[') + std::string(depth, ']');
}

TEST_F(HostileCrash, GltfNested20000LevelsIsRefusedNamingTheFile) {
    write("tet.bin", tetBin());
    write("deep.gltf", tetGltf("\"uri\": \"tet.bin\", ", "0", "0", "0", ", \"extras\": " + nested(20000)));
    refused("play deep.gltf --frames 2 --levels 1", 1, {"deep.gltf", "nests deeper than 128"});
}

TEST_F(HostileCrash, GlbNested20000LevelsIsRefusedNamingTheFile) {
    write("deep.glb", glb(tetGltf("", "0", "0", "0", ", \"extras\": " + nested(20000)), tetBin()));
    refused("play deep.glb --frames 2 --levels 1", 1, {"deep.glb", "nests deeper than 128"});
}

TEST_F(HostileCrash, BracketsInsideStringsAreNotNesting) {
    write("tet.bin", tetBin());
    write("strings.gltf", tetGltf("\"uri\": \"tet.bin\", ", "0", "0", "0",
                                  ", \"extras\": {\"text\": \"" + nested(500) + "\\\"[[\"}"));
    const Run run = psub("play strings.gltf --frames 2 --levels 1");
    EXPECT_EQ(run.status, 0) << run.err;
}

TEST(HostileCrashLibrary, ReadGltfThrowsInputErrorOnDeepNesting) {
    const fs::path file = fs::path(testing::TempDir()) / ("psub-deep-" + std::to_string(::getpid()) + ".gltf");
    std::ofstream(file) << "{\"asset\": {\"version\": \"2.0\"}, \"extras\": " << nested(129) << "}";
    const std::string message = [&] {
        try {
            readGltf(file.string());
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string("(no error)");
    }();
    fs::remove(file);
    EXPECT_TRUE(contains(message, file.string() + ": the JSON nests deeper than 128")) << message;
}

}  // namespace
}  // namespace psub::test
