// The animation layer: procedural deformers (names, identity at t = 0, periodicity, the
// documented formulas) and glTF playback on files written here at run time with tinygltf's
// writer (a two-bone cylinder, a morphed quad, broken files), checked against hand-computed
// poses. Global operator new is counted so that the per-frame calls can be shown not to allocate.
#include "psub/animation.h"
#include "psub/evaluator.h"
#include "psub/stencils.h"

#include <gtest/gtest.h>
#include "gltf_models.h"
#include "test_support.h"
#include <tiny_gltf.h>

#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <new>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

namespace {
std::atomic<std::size_t> allocations{0};
}  // namespace

void* operator new(std::size_t size) {
    ++allocations;
    if (void* memory = std::malloc(size == 0 ? 1 : size)) return memory;
    throw std::bad_alloc();
}
// Out of line, so that GCC does not pair an inlined free() with `new` (-Wmismatched-new-delete).
[[gnu::noinline]] void operator delete(void* memory) noexcept { std::free(memory); }
[[gnu::noinline]] void operator delete(void* memory, std::size_t) noexcept { std::free(memory); }

namespace psub {
namespace {

namespace fs = std::filesystem;
using namespace psub::test;
using test::inputErrorOf;
constexpr double kPi = std::numbers::pi;

using test::contains;

// ---------------------------------------------------------------------------------------
// Procedural

// A lattice of points filling the box [0, 4] x [0, 1] x [0, 2] (longest x, shortest y).
std::vector<float> lattice() {
    std::vector<float> points;
    for (int i = 0; i <= 8; ++i)
        for (int j = 0; j <= 2; ++j)
            for (int k = 0; k <= 4; ++k)
                points.insert(points.end(), {0.5f * float(i), 0.5f * float(j), 0.5f * float(k)});
    return points;
}

std::vector<float> deformed(Procedural kind, const std::vector<float>& rest, double seconds) {
    std::vector<float> out(rest.size());
    deformProcedural(kind, restBounds(rest), rest, seconds, out);
    return out;
}

TEST(Procedural, NamesRoundTrip) {
    for (Procedural kind : {Procedural::Wave, Procedural::Twist, Procedural::Bend})
        EXPECT_EQ(parseProcedural(proceduralName(kind)), kind);
    EXPECT_EQ(parseProcedural("twist"), Procedural::Twist);
    EXPECT_FALSE(parseProcedural("Twist"));
    EXPECT_FALSE(parseProcedural("spin"));
    EXPECT_FALSE(parseProcedural(""));
}

TEST(Procedural, RestBoundsIsTheBoxOfThePoints) {
    const std::vector<float> points = {1, -2, 3, -4, 5, 0.5f, 2, 2, -6};
    const RestBounds bounds = restBounds(points);
    EXPECT_EQ(bounds.min, (std::array<double, 3>{-4, -2, -6}));
    EXPECT_EQ(bounds.max, (std::array<double, 3>{2, 5, 3}));
    const RestBounds none = restBounds({});
    EXPECT_EQ(none.min, (std::array<double, 3>{0, 0, 0}));
    EXPECT_EQ(none.max, (std::array<double, 3>{0, 0, 0}));
}

TEST(Procedural, TwistAndBendAreTheIdentityAtTimeZero) {
    const std::vector<float> rest = lattice();
    EXPECT_EQ(deformed(Procedural::Twist, rest, 0.0), rest);
    EXPECT_EQ(deformed(Procedural::Bend, rest, 0.0), rest);
    EXPECT_NE(deformed(Procedural::Twist, rest, 0.3), rest);
    EXPECT_NE(deformed(Procedural::Bend, rest, 0.3), rest);
}

TEST(Procedural, EveryDeformerIsPeriodicInTime) {
    const std::vector<float> rest = lattice();
    for (Procedural kind : {Procedural::Wave, Procedural::Twist, Procedural::Bend})
        for (double t : {0.0, 0.37, 1.2}) {
            const std::vector<float> now = deformed(kind, rest, t);
            for (double later : {t + kProceduralPeriod, t + 3 * kProceduralPeriod, t - kProceduralPeriod}) {
                const std::vector<float> then = deformed(kind, rest, later);
                // Tolerance 1e-5: float coordinates up to 4 (ulp 4.8e-7) through a sine of a phase
                // a few periods away (its float rounding scaled by the amplitude): a few ulps.
                for (std::size_t i = 0; i < rest.size(); ++i)
                    ASSERT_NEAR(then[i], now[i], 1e-5) << proceduralName(kind) << " t=" << t << " value " << i;
            }
            if (kind != Procedural::Wave || t != 0.0) continue;
            const std::vector<float> half = deformed(kind, rest, t + kProceduralPeriod / 4);
            EXPECT_NE(half, now);  // it does move in between
        }
}

TEST(Procedural, WaveMovesOnlyTheUpAxisByTheDocumentedSine) {
    // Box [0,4] x [0,1] x [0,2]: up = y (shortest), travel = x (longest other), L = 4.
    const std::vector<float> rest = lattice();
    const double t = 0.3, size = 4;
    const std::vector<float> out = deformed(Procedural::Wave, rest, t);
    for (std::size_t i = 0; i < rest.size(); i += 3) {
        EXPECT_EQ(out[i], rest[i]);
        EXPECT_EQ(out[i + 2], rest[i + 2]);
        const double expected = rest[i + 1] + kWaveAmplitude * size *
                                                  std::sin(2 * kPi * rest[i] / (size / 2) -
                                                           2 * kPi * t / kProceduralPeriod);
        EXPECT_NEAR(out[i + 1], expected, 1e-6);  // float results below 4: ulp 4.8e-7, 2 ulps
    }
}

TEST(Procedural, TwistTurnsTheEndsByHalfTheTwistAngleAtThePeak) {
    // Longest axis x through the centre (2, 0.5, 1); at a quarter period sin(phase) = 1.
    const std::vector<float> rest = lattice();
    const std::vector<float> out = deformed(Procedural::Twist, rest, kProceduralPeriod / 4);
    for (std::size_t i = 0; i < rest.size(); i += 3) {
        const double theta = kTwistAngle * (rest[i] - 2.0) / 4.0;  // +-pi/4 at the ends
        const double qy = rest[i + 1] - 0.5, qz = rest[i + 2] - 1.0;
        EXPECT_EQ(out[i], rest[i]);
        EXPECT_NEAR(out[i + 1], 0.5 + std::cos(theta) * qy - std::sin(theta) * qz, 1e-6);
        EXPECT_NEAR(out[i + 2], 1.0 + std::sin(theta) * qy + std::cos(theta) * qz, 1e-6);
    }
    // The end x = 4 turned by exactly pi/4: the corner (4, 1, 2) has angle atan2(1, 0.5) + pi/4.
    const std::size_t corner = rest.size() - 3;
    ASSERT_EQ(rest[corner], 4.0f);
    EXPECT_NEAR(std::atan2(out[corner + 2] - 1.0, out[corner + 1] - 0.5), std::atan2(1.0, 0.5) + kPi / 4, 1e-6);
}

TEST(Procedural, BendPutsTheAxisOnAnArcOfTheDocumentedCurvature) {
    // Axis a = x (longest), towards b = z (longer of y, z); centre line y and z at the centre.
    const std::vector<float> rest = lattice();
    const std::vector<float> out = deformed(Procedural::Bend, rest, kProceduralPeriod / 4);
    const double radius = 4.0 / kBendAngle;  // curvature kBendAngle / L
    // Tolerance 1e-5: float results of sin/cos scaled by the radius (> L = 4): a few ulps of it.
    for (std::size_t i = 0; i < rest.size(); i += 3) {
        if (rest[i + 2] != 1.0f) continue;  // on the centre line in z: lands on the arc
        const double phi = (rest[i] - 2.0) / radius;
        EXPECT_NEAR(out[i], 2.0 + radius * std::sin(phi), 1e-5);
        EXPECT_NEAR(out[i + 2], 1.0 + radius * (1 - std::cos(phi)), 1e-5);
        EXPECT_EQ(out[i + 1], rest[i + 1]);
        EXPECT_NEAR(std::hypot(out[i] - 2.0, out[i + 2] - (1.0 + radius)), radius, 1e-5);
    }
}

// A mesh large enough to be deformed on all cores gives, for every vertex, what deforming that
// vertex alone (one thread) gives: the threads change nothing.
TEST(Procedural, LargeMeshesOnAllCoresEqualEachVertexAlone) {
    std::mt19937 random(3);
    std::uniform_real_distribution<float> uniform(-2.0f, 2.0f);
    std::vector<float> rest(3 * 40000);
    for (float& x : rest) x = uniform(random);
    const RestBounds bounds = restBounds(rest);
    std::vector<float> out(rest.size()), one(3);
    for (Procedural kind : {Procedural::Wave, Procedural::Twist, Procedural::Bend}) {
        deformProcedural(kind, bounds, rest, 0.7, out);
        for (std::size_t i = 0; i < rest.size(); i += 3) {
            deformProcedural(kind, bounds, std::span<const float>(rest).subspan(i, 3), 0.7, one);
            ASSERT_TRUE(std::equal(one.begin(), one.end(), out.begin() + std::ptrdiff_t(i)))
                << proceduralName(kind) << " vertex " << i / 3;
        }
    }
}

TEST(Procedural, DeformingAllocatesNothing) {
    const std::vector<float> rest = lattice();
    std::vector<float> out(rest.size());
    const RestBounds bounds = restBounds(rest);
    const std::size_t before = allocations.load();
    for (Procedural kind : {Procedural::Wave, Procedural::Twist, Procedural::Bend})
        deformProcedural(kind, bounds, rest, 0.7, out);
    EXPECT_EQ(allocations.load(), before);
}

TEST(Procedural, APlaybackFrameAllocatesNothing) {
    // What `psub play` does per frame on the CPU: deform, evaluate the tables, normals. After a
    // first frame (OpenMP starts its threads), no frame allocates.
    Mesh mesh = readObj(PSUB_DATA "/spot_control_mesh.obj");
    const CheckedMesh checked = checkMesh(mesh);
    RefineOptions options;
    options.levels = 6;  // 23k vertices: big enough for the evaluator to use every thread
    const Refinement r = refine(mesh, checked.connectivity, options);
    CpuEvaluator<float> evaluator(r.perLevel, r.factorized, r.surface, TableForm::PerLevel, 3, 2);
    const std::vector<float> rest(mesh.positions.begin(), mesh.positions.end());
    const RestBounds bounds = restBounds(rest);
    std::vector<float> control(rest.size()), refined(3 * std::size_t(evaluator.refinedCount())), normals(refined.size());
    const auto frame = [&](int k) {
        deformProcedural(Procedural::Twist, bounds, rest, k / 30.0, control);
        evaluator.evaluate(control, refined);
        evaluator.normals(refined, normals);
    };
    frame(0);
    const std::size_t before = allocations.load();
    for (int k = 1; k <= 10; ++k) frame(k);
    EXPECT_EQ(allocations.load(), before);
}

// ---------------------------------------------------------------------------------------
// glTF files written here

// Builds a tinygltf model: one buffer, one buffer view per accessor.
// A unit quad (two indexed triangles) in z = 0, node 0 holding it at `translation`; one
// morph target moving vertex 0 by (0, 0, 1), default weight 0.5; clip "morph": weight 0 -> 1.
ModelBuilder makeMorphedQuad(std::vector<double> translation = {}) {
    ModelBuilder b;
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    primitive.attributes["POSITION"] = b.positions({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});
    primitive.indices = b.indices({0, 1, 2, 0, 2, 3});
    primitive.targets.push_back({{"POSITION", b.positions({0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0})}});
    tinygltf::Mesh mesh;
    mesh.primitives.push_back(primitive);
    mesh.weights = {0.5};
    b.model.meshes.push_back(mesh);
    tinygltf::Node node;
    node.mesh = 0;
    node.translation = std::move(translation);
    b.model.nodes.push_back(node);
    b.clip("morph", 0, "weights", "LINEAR", {0, 1}, {0, 1}, TINYGLTF_TYPE_SCALAR, 1);
    return b;
}

class Gltf : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("psub_animation_" + std::to_string(::getpid()) + "_" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    std::string write(const tinygltf::Model& model, const std::string& name) {
        const std::string path = (dir_ / name).string();
        tinygltf::TinyGLTF writer;
        const bool binary = name.ends_with(".glb");
        EXPECT_TRUE(writer.WriteGltfSceneToFile(&model, path, true, true, true, binary)) << path;
        return path;
    }
    std::string writeText(const std::string& name, const std::string& text) {
        const std::string path = (dir_ / name).string();
        std::ofstream(path, std::ios::binary) << text;
        return path;
    }
    std::string readText(const std::string& path) {
        std::ifstream in(path, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }
    // The message readGltf gives for `model`, which must mention the file and every part.
    void expectError(const tinygltf::Model& model, const std::vector<std::string>& parts) {
        const std::string path = write(model, "bad.gltf");
        const std::string message = inputErrorOf([&] { readGltf(path); });
        EXPECT_TRUE(contains(message, path + ": ")) << message;
        for (const std::string& part : parts) EXPECT_TRUE(contains(message, part)) << message << " / " << part;
    }

    fs::path dir_;
};

// The cage vertex of the cylinder's (ring, column), through the lower primitive when it has it.
Index cageVertex(const GltfAsset& asset, int ring, int column) {
    const std::size_t primitive = ring <= 2 ? 0 : 1;
    const std::size_t local = std::size_t((ring - (primitive == 0 ? 0 : 2)) * kRowSize + column);
    return asset.cageVertexOf[asset.primitiveFirstVertex[primitive] + local];
}

std::array<float, 3> at(const std::vector<float>& positions, Index v) {
    return {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]};
}

// p rotated by `angle` about z around the point (0, 1, 0): joint 1's motion in clip "bend".
std::array<double, 3> aboutJoint1(const std::array<float, 3>& p, double angle) {
    const double x = p[0], y = p[1] - 1.0;
    return {std::cos(angle) * x - std::sin(angle) * y, 1.0 + std::sin(angle) * x + std::cos(angle) * y, p[2]};
}

void expectNear(const std::array<float, 3>& actual, const std::array<double, 3>& expected, double tolerance = 1e-5) {
    for (int axis = 0; axis < 3; ++axis)
        EXPECT_NEAR(actual[std::size_t(axis)], expected[std::size_t(axis)], tolerance) << "axis " << axis;
}

TEST_F(Gltf, WeldsSeamsAndTheRingSharedByTwoPrimitives) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    EXPECT_EQ(asset.cageVertexOf.size(), std::size_t(2 * 3 * kRowSize));
    EXPECT_EQ(asset.primitiveFirstVertex, (std::vector<Index>{0, 3 * kRowSize}));
    EXPECT_EQ(asset.mesh.faces.vertexCount, Index(kRings * kColumns));
    EXPECT_EQ(asset.mesh.positions.size(), std::size_t(3 * kRings * kColumns));
    EXPECT_EQ(asset.mesh.faces.faceCount(), Index(2 * (kRings - 1) * kColumns));
    EXPECT_EQ(cageVertex(asset, 1, kColumns), cageVertex(asset, 1, 0));  // the seam
    EXPECT_EQ(asset.cageVertexOf[asset.primitiveFirstVertex[1]], cageVertex(asset, 2, 0));  // ring 2
    EXPECT_NO_THROW(checkMesh(asset.mesh));  // a manifold open cylinder, consistently oriented
    EXPECT_EQ(asset.mesh.source.path, (dir_ / "cylinder.gltf").string());
    EXPECT_EQ(asset.meshNode, 2u);  // gltf_models.h's nodes: root, mid, holder (the mesh), prop
    EXPECT_TRUE(asset.warnings.empty());
}

TEST_F(Gltf, DifferentWeightsKeepVerticesApart) {
    const GltfAsset asset = readGltf(write(makeCylinder(0.6f).builder.model, "cylinder.gltf"));
    EXPECT_EQ(asset.mesh.faces.vertexCount, Index(kRings * kColumns + kColumns));  // ring 2 twice
    EXPECT_NE(asset.cageVertexOf[asset.primitiveFirstVertex[1]], cageVertex(asset, 2, 0));
}

TEST_F(Gltf, LoadsJointsWeightsAndInverseBindMatricesAsWritten) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    ASSERT_TRUE(asset.skin);
    const GltfSkin& skin = *asset.skin;
    EXPECT_EQ(skin.jointNodes, (std::vector<std::uint32_t>{0, 1}));
    ASSERT_EQ(skin.inverseBindMatrices.size(), 2u);
    // Joint 1 ("mid") sits at y = 1, so its inverse bind matrix moves by -1 in y: element 13
    // of the column-major 4 x 4 matrix; joint 0 at the origin has 0 there.
    EXPECT_EQ(skin.inverseBindMatrices[1][13], -1.0);
    EXPECT_EQ(skin.inverseBindMatrices[0][13], 0.0);
    ASSERT_EQ(skin.joints.size(), 4u * asset.mesh.faces.vertexCount);
    for (int ring = 1; ring < kRings - 1; ++ring) {
        const Index v = cageVertex(asset, ring, 3);
        EXPECT_EQ(skin.joints[4 * v], 0);
        EXPECT_EQ(skin.joints[4 * v + 1], 1);
        EXPECT_FLOAT_EQ(skin.weights[4 * v], 1 - kJoint1Weight[ring]);
        EXPECT_FLOAT_EQ(skin.weights[4 * v + 1], kJoint1Weight[ring]);
        EXPECT_EQ(skin.weights[4 * v + 2], 0.0f);
    }
    const Index base = cageVertex(asset, 0, 0);  // weight 0 on joint 1: that slot reads joint 0
    EXPECT_EQ(skin.weights[4 * base], 1.0f);
    EXPECT_EQ(skin.joints[4 * base + 1], 0);
    ASSERT_EQ(asset.nodes.size(), 4u);  // root, mid, holder, prop
    EXPECT_EQ(asset.nodes[1].parent, 0);
    EXPECT_EQ(asset.nodes[1].name, "mid");
    EXPECT_EQ(asset.nodes[1].rest.translation, (std::array<double, 3>{0, 1, 0}));
    EXPECT_EQ(asset.nodes[2].parent, -1);
}

TEST_F(Gltf, WeightsAreNormalised) {
    Cylinder cylinder = makeCylinder();
    for (std::size_t v = 0; v < 3 * kRowSize; ++v)  // lower primitive: weights times 4
        for (std::size_t k = 0; k < 2; ++k) {
            const float w = k == 0 ? 1 - kJoint1Weight[v / kRowSize] : kJoint1Weight[v / kRowSize];
            cylinder.builder.patch(cylinder.accessors.weights[0], v, k, 4 * w);
        }
    const GltfAsset asset = readGltf(write(cylinder.builder.model, "cylinder.gltf"));
    const Index v = cageVertex(asset, 1, 0);
    EXPECT_FLOAT_EQ(asset.skin->weights[4 * v], 0.75f);
    EXPECT_FLOAT_EQ(asset.skin->weights[4 * v + 1], 0.25f);
    EXPECT_EQ(asset.mesh.faces.vertexCount, Index(kRings * kColumns));  // ring 2 still welds
}

TEST_F(Gltf, RestPoseIsTheWrittenPositions) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    GltfPlayer player(asset);
    std::vector<float> rest(3 * player.vertexCount()), still(rest.size());
    player.restPose(rest);
    for (int ring = 0; ring < kRings; ++ring)
        for (int column = 0; column < kRowSize; ++column)
            EXPECT_EQ(at(rest, cageVertex(asset, ring, column)), cylinderPoint(ring, column));
    player.staticPose(still);  // bind pose: joints at their bind transforms
    for (std::size_t i = 0; i < rest.size(); ++i) EXPECT_NEAR(still[i], rest[i], 1e-6);
}

TEST_F(Gltf, KnownPoseRotatesFullyBoundVerticesAndAveragesSharedOnes) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    GltfPlayer player(asset);
    std::vector<float> rest(3 * player.vertexCount()), posed(rest.size());
    player.restPose(rest);
    player.pose(*findClip(asset, "bend"), 1.0, posed, /*loop=*/false);  // 90 degrees about z
    for (int column = 0; column < kColumns; ++column) {
        const Index top = cageVertex(asset, 4, column), middle = cageVertex(asset, 2, column);
        const Index base = cageVertex(asset, 0, column);
        expectNear(at(posed, top), aboutJoint1(at(rest, top), kPi / 2));
        const auto turned = aboutJoint1(at(rest, middle), kPi / 2);
        const auto still = at(rest, middle);
        expectNear(at(posed, middle), {0.5 * (still[0] + turned[0]), 0.5 * (still[1] + turned[1]),
                                       0.5 * (still[2] + turned[2])});
        expectNear(at(posed, base), {rest[3 * base], rest[3 * base + 1], rest[3 * base + 2]}, 0);
    }
    // Hand-computed: the top vertex (0.5, 2, 0) goes to (-1, 1.5, 0).
    expectNear(at(posed, cageVertex(asset, 4, 0)), {-1.0, 1.5, 0.0});
}

TEST_F(Gltf, LinearRotationIsSlerped) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    GltfPlayer player(asset);
    std::vector<float> rest(3 * player.vertexCount()), posed(rest.size());
    player.restPose(rest);
    for (double t : {0.25, 0.5, 0.8}) {
        player.pose(*findClip(asset, "bend"), t, posed);
        const double halfAngle = t * kPi / 4;  // slerp: the angle grows linearly (nlerp would not)
        const auto& q = player.localTransform(1).rotation;
        // Tolerance 1e-7: the keys are float quaternions (ulp of 1: 1.2e-7, half of it rounding).
        EXPECT_NEAR(q[0], 0, 1e-7);
        EXPECT_NEAR(q[1], 0, 1e-7);
        EXPECT_NEAR(q[2], std::sin(halfAngle), 1e-7) << "t=" << t;
        EXPECT_NEAR(q[3], std::cos(halfAngle), 1e-7) << "t=" << t;
        const Index top = cageVertex(asset, 4, 2);
        expectNear(at(posed, top), aboutJoint1(at(rest, top), 2 * halfAngle));
    }
    EXPECT_EQ(player.localTransform(0).rotation, (std::array<double, 4>{0, 0, 0, 1}));  // untouched
}

TEST_F(Gltf, StepHoldsEachValueUntilTheNextKey) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    GltfPlayer player(asset);
    std::vector<float> rest(3 * player.vertexCount()), posed(rest.size());
    player.restPose(rest);
    const std::size_t step = *findClip(asset, "step");
    const std::vector<std::pair<double, double>> expected = {{0.0, 0.0}, {0.25, 0.0}, {0.4999, 0.0},
                                                             {0.5, 0.5}, {0.75, 0.5}};
    for (const auto& [t, x] : expected) {
        player.pose(step, t, posed);
        EXPECT_EQ(player.localTransform(1).translation, (std::array<double, 3>{x, 1, 0})) << "t=" << t;
        const Index top = cageVertex(asset, 4, 1);
        expectNear(at(posed, top), {rest[3 * top] + x, rest[3 * top + 1], rest[3 * top + 2]});
    }
    player.pose(step, 1.0, posed, /*loop=*/false);
    EXPECT_EQ(player.localTransform(1).translation, (std::array<double, 3>{1, 1, 0}));
}

TEST_F(Gltf, LoopingWrapsAndClampingHolds) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    GltfPlayer player(asset);
    const std::size_t bend = *findClip(asset, "bend");
    EXPECT_EQ(asset.clips[bend].duration, 1.0);
    std::vector<float> reference(3 * player.vertexCount()), other(reference.size());
    player.pose(bend, 0.25, reference);
    for (double t : {1.25, 3.25, -0.75}) {
        player.pose(bend, t, other);
        // Float positions below 4 (ulp 4.8e-7) after times a whole number of loops apart: 2 ulps.
        for (std::size_t i = 0; i < reference.size(); ++i) ASSERT_NEAR(other[i], reference[i], 1e-6) << "t=" << t;
    }
    player.pose(bend, 1.0, reference, false);
    player.pose(bend, 7.5, other, false);
    EXPECT_EQ(other, reference);
    player.pose(bend, 1.0, other);  // looping: the end is the start again
    EXPECT_NEAR(player.localTransform(1).rotation[3], 1.0, 1e-12);
}

TEST_F(Gltf, CubicSplineFollowsTheHermiteCurve) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    GltfPlayer player(asset);
    std::vector<float> posed(3 * player.vertexCount());
    player.pose(*findClip(asset, "cubic"), 0.5, posed);
    // Values 0 -> 1 in x, out-tangent 1 at key 0, time step 1: 0.5 + (s^3 - 2 s^2 + s) = 0.625.
    EXPECT_NEAR(player.localTransform(1).translation[0], 0.625, 1e-7);
    EXPECT_NEAR(player.localTransform(1).translation[1], 1.0, 1e-7);
    player.pose(*findClip(asset, "cubic"), 0.0, posed);
    EXPECT_EQ(player.localTransform(1).translation, (std::array<double, 3>{0, 1, 0}));
}

TEST_F(Gltf, ClipOnANodeOutsideTheSkinChangesNothing) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    GltfPlayer player(asset);
    std::vector<float> still(3 * player.vertexCount()), posed(still.size());
    player.staticPose(still);
    player.pose(*findClip(asset, "prop"), 1.0, posed);
    // Clip "prop": (0, 0, 0) at time 0 to (5, 5, 5) at time 2, linear: half way at time 1.
    EXPECT_EQ(player.localTransform(3).translation, (std::array<double, 3>{2.5, 2.5, 2.5}));
    EXPECT_EQ(posed, still);
}

// data/two_bone_cylinder.glb is this file's cylinder, written as .glb. PSUB_REGENERATE_DATA=1
// rewrites it from the builder (after a change to tests/gltf_models.h); the test then passes.
TEST_F(Gltf, BundledCylinderIsTheTestModel) {
    const std::string generated = readText(write(makeCylinder().builder.model, "cylinder.glb"));
    const std::string bundled = dataPath("two_bone_cylinder.glb");
    if (const char* regenerate = std::getenv("PSUB_REGENERATE_DATA"); regenerate && std::string(regenerate) == "1")
        std::ofstream(bundled, std::ios::binary) << generated;
    EXPECT_TRUE(readText(bundled) == generated)
        << bundled << " differs from makeCylinder(): rerun with PSUB_REGENERATE_DATA=1";
}

TEST_F(Gltf, MorphTargetWithWeightHalfGivesHalfTheDelta) {
    const GltfAsset asset = readGltf(write(makeMorphedQuad().model, "quad.gltf"));
    EXPECT_EQ(asset.morphs.targetCount, 1u);
    EXPECT_EQ(asset.morphs.defaultWeights, (std::vector<float>{0.5f}));
    EXPECT_FALSE(asset.skin);
    GltfPlayer player(asset);
    std::vector<float> rest(3 * player.vertexCount()), posed(rest.size());
    player.restPose(rest);
    player.staticPose(posed);
    const Index v0 = asset.cageVertexOf[0];
    expectNear(at(posed, v0), {0, 0, 0.5});
    for (Index v = 0; v < player.vertexCount(); ++v) {
        if (v == v0) continue;
        EXPECT_EQ(at(posed, v), at(rest, v));
    }
    player.pose(0, 0.25, posed);
    EXPECT_FLOAT_EQ(player.morphWeights()[0], 0.25f);
    expectNear(at(posed, v0), {0, 0, 0.25});
}

TEST_F(Gltf, SparseMorphTargetLoads) {
    ModelBuilder b = makeMorphedQuad();
    tinygltf::Accessor sparse;  // no buffer view: zeros, then vertex 2 := (0, 0, 2)
    sparse.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    sparse.type = TINYGLTF_TYPE_VEC3;
    sparse.count = 4;
    sparse.sparse.isSparse = true;
    sparse.sparse.count = 1;
    const std::uint16_t index = 2;
    const float value[3] = {0, 0, 2};
    sparse.sparse.indices.bufferView = b.view(&index, sizeof index);
    sparse.sparse.indices.byteOffset = 0;
    sparse.sparse.indices.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    sparse.sparse.values.bufferView = b.view(value, sizeof value);
    sparse.sparse.values.byteOffset = 0;
    b.model.accessors.push_back(sparse);
    b.model.meshes[0].primitives[0].targets[0]["POSITION"] = int(b.model.accessors.size() - 1);
    const GltfAsset asset = readGltf(write(b.model, "sparse.gltf"));
    GltfPlayer player(asset);
    std::vector<float> posed(3 * player.vertexCount());
    player.staticPose(posed);  // default weight 0.5
    expectNear(at(posed, asset.cageVertexOf[2]), {1, 1, 1});
    expectNear(at(posed, asset.cageVertexOf[0]), {0, 0, 0});
}

TEST_F(Gltf, MeshWithoutSkinFollowsItsNode) {
    const GltfAsset asset = readGltf(write(makeMorphedQuad({10, 0, 0}).model, "quad.gltf"));
    GltfPlayer player(asset);
    std::vector<float> rest(3 * player.vertexCount()), posed(rest.size());
    player.restPose(rest);
    player.staticPose(posed);
    const Index v2 = asset.cageVertexOf[2];
    expectNear(at(rest, v2), {1, 1, 0}, 0);
    expectNear(at(posed, v2), {11, 1, 0});
}

TEST_F(Gltf, BinaryFileLoadsTheSameAsText) {
    const Cylinder cylinder = makeCylinder();
    const GltfAsset text = readGltf(write(cylinder.builder.model, "cylinder.gltf"));
    const GltfAsset binary = readGltf(write(cylinder.builder.model, "cylinder.glb"));
    EXPECT_EQ(binary.mesh.positions, text.mesh.positions);
    EXPECT_EQ(binary.mesh.faces.verts, text.mesh.faces.verts);
    EXPECT_EQ(binary.cageVertexOf, text.cageVertexOf);
    ASSERT_EQ(binary.clips.size(), 4u);
    EXPECT_EQ(binary.clips[0].name, "bend");
    EXPECT_EQ(binary.clips[2].channels[0].interpolation, GltfInterpolation::CubicSpline);
}

TEST_F(Gltf, PosingAllocatesNothing) {
    const GltfAsset asset = readGltf(write(makeCylinder().builder.model, "cylinder.gltf"));
    GltfPlayer player(asset);
    std::vector<float> posed(3 * player.vertexCount());
    const std::size_t before = allocations.load();
    for (std::size_t clip = 0; clip < player.clipCount(); ++clip) player.pose(clip, 0.3, posed);
    player.staticPose(posed);
    player.restPose(posed);
    EXPECT_EQ(allocations.load(), before);
}

// ---------------------------------------------------------------------------------------
// Bad files

TEST_F(Gltf, MissingEmptyAndNonGltfFilesAreInputErrors) {
    const std::string missing = (dir_ / "missing.gltf").string();
    EXPECT_TRUE(contains(inputErrorOf([&] { readGltf(missing); }), missing + ": cannot open"));
    const std::string empty = writeText("empty.gltf", "");
    EXPECT_TRUE(contains(inputErrorOf([&] { readGltf(empty); }), empty + ": "));
    const std::string prose = writeText("prose.gltf", "this is not JSON at all\n");
    EXPECT_TRUE(contains(inputErrorOf([&] { readGltf(prose); }), prose + ": not a valid glTF"));
    const std::string json = writeText("other.gltf", R"({"hello": [1, 2, 3]})");
    EXPECT_TRUE(contains(inputErrorOf([&] { readGltf(json); }), json + ": "));
    const std::string fakeGlb = writeText("fake.glb", std::string("glTF\x02\0\0\0garbage and more garbage", 31));
    EXPECT_TRUE(contains(inputErrorOf([&] { readGltf(fakeGlb); }), fakeGlb + ": not a valid glTF binary"));
    EXPECT_TRUE(contains(inputErrorOf([&] { readGltf(dir_.string()); }), dir_.string() + ": "));
}

TEST_F(Gltf, TruncatedFilesAreInputErrors) {
    const Cylinder cylinder = makeCylinder();
    for (const std::string name : {"whole.glb", "whole.gltf"}) {
        const std::string whole = readText(write(cylinder.builder.model, name));
        ASSERT_GT(whole.size(), 100u);
        const bool binary = name.ends_with(".glb");  // the GLB header holds the length
        const std::size_t end = binary ? whole.size() : whole.rfind('}');  // JSON: up to the last brace
        for (std::size_t size = 0; size < end; size += binary ? 3 : 11) {  // every residue mod 4 and 8
            const std::string path = writeText("cut_" + name, whole.substr(0, size));
            const std::string message = inputErrorOf([&] { readGltf(path); });
            ASSERT_TRUE(contains(message, path + ": ")) << size << " bytes: " << message;
        }
    }
}

// Numbers in the JSON (indices, counts, offsets, modes, keyframes) changed at random: the file
// loads and plays, or is an InputError; never a crash (run under ASan/UBSan in CI).
TEST_F(Gltf, FilesWithRandomlyChangedNumbersLoadOrAreInputErrors) {
    const std::string whole = readText(write(makeCylinder().builder.model, "whole.gltf"));
    const std::size_t dataBegin = whole.find("base64,"), dataEnd = whole.find('"', dataBegin);
    ASSERT_NE(dataBegin, std::string::npos);
    std::vector<std::size_t> digits;
    for (std::size_t i = 0; i < whole.size(); ++i)
        if (std::isdigit(static_cast<unsigned char>(whole[i])) && (i < dataBegin || i > dataEnd)) digits.push_back(i);
    std::mt19937 random(12345);
    std::size_t loaded = 0, rejected = 0;
    for (int trial = 0; trial < 400; ++trial) {
        std::string text = whole;
        for (int change = 0; change < 1 + trial % 3; ++change)
            text[digits[random() % digits.size()]] = char('0' + random() % 10);
        const std::string path = writeText("changed.gltf", text);
        try {
            const GltfAsset asset = readGltf(path);
            GltfPlayer player(asset);
            std::vector<float> posed(3 * player.vertexCount());
            player.staticPose(posed);
            for (std::size_t clip = 0; clip < player.clipCount(); ++clip)
                for (double t : {-0.3, 0.0, 0.4, 1.0, 2.7}) player.pose(clip, t, posed);
            ++loaded;
        } catch (const InputError& error) {
            ASSERT_TRUE(contains(error.what(), path + ": ")) << error.what();
            ++rejected;
        }
    }
    EXPECT_GT(loaded, 0u);  // the mutations are not all fatal...
    EXPECT_GT(rejected, 0u);  // ...nor all harmless
}

TEST_F(Gltf, FileWithoutAMeshNamesIt) {
    ModelBuilder b;
    b.model.buffers.clear();
    b.model.nodes.emplace_back().name = "lonely";
    expectError(b.model, {"no mesh"});
    ModelBuilder quad = makeMorphedQuad();
    quad.model.nodes[0].mesh = -1;  // a mesh that no node instantiates
    quad.model.nodes[0].name = "empty";  // tinygltf writes a node with no property as null
    quad.model.animations.clear();
    expectError(quad.model, {"no node instantiates"});
}

TEST_F(Gltf, PointsAndLinesAreRejected) {
    Cylinder cylinder = makeCylinder();
    cylinder.builder.model.meshes[0].primitives[1].mode = TINYGLTF_MODE_LINE;
    expectError(cylinder.builder.model, {"mesh 0 primitive 1", "mode 1", "triangles"});
}

TEST_F(Gltf, TriangleStripsAndFansAreTriangles) {
    ModelBuilder b = makeMorphedQuad();
    b.model.meshes[0].primitives[0].mode = TINYGLTF_MODE_TRIANGLE_FAN;
    b.model.meshes[0].primitives[0].indices = b.indices({0, 1, 2, 3});
    GltfAsset asset = readGltf(write(b.model, "fan.gltf"));
    EXPECT_EQ(asset.mesh.faces.verts, (std::vector<Index>{1, 2, 0, 2, 3, 0}));
    b.model.meshes[0].primitives[0].mode = TINYGLTF_MODE_TRIANGLE_STRIP;
    b.model.meshes[0].primitives[0].indices = b.indices({0, 1, 3, 2});
    asset = readGltf(write(b.model, "strip.gltf"));
    EXPECT_EQ(asset.mesh.faces.verts, (std::vector<Index>{0, 1, 3, 1, 2, 3}));
}

TEST_F(Gltf, IndexOutOfRangeNamesTheAccessor) {
    Cylinder cylinder = makeCylinder();
    const int indices = cylinder.accessors.indices[1];
    cylinder.builder.patch<std::uint32_t>(indices, 5, 0, 999);
    expectError(cylinder.builder.model,
                {"accessor " + std::to_string(indices), "mesh 0 primitive 1 indices", "index 5", "out of range"});
}

TEST_F(Gltf, JointOutOfRangeNamesTheAccessorAndVertex) {
    Cylinder cylinder = makeCylinder();
    const int joints = cylinder.accessors.joints[0];
    cylinder.builder.patch<std::uint16_t>(joints, 12, 1, 7);  // vertex 12: ring 1, weight 0.25 on slot 1
    expectError(cylinder.builder.model, {"accessor " + std::to_string(joints), "JOINTS_0", "vertex 12", "joint 7"});
}

TEST_F(Gltf, NanOrNegativeOrZeroWeightsAreRejected) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (const float bad : {nan, -0.5f}) {
        Cylinder cylinder = makeCylinder();
        const int weights = cylinder.accessors.weights[1];
        cylinder.builder.patch(weights, 3, 0, bad);
        expectError(cylinder.builder.model, {"accessor " + std::to_string(weights), "WEIGHTS_0", "vertex 3"});
    }
    Cylinder cylinder = makeCylinder();
    cylinder.builder.patch(cylinder.accessors.weights[0], 0, 0, 0.0f);  // ring 0: (1, 0) -> (0, 0)
    expectError(cylinder.builder.model, {"WEIGHTS_0", "vertex 0", "sum to 0"});
}

TEST_F(Gltf, NonFinitePositionIsRejected) {
    Cylinder cylinder = makeCylinder();
    cylinder.builder.patch(cylinder.accessors.positions[0], 4, 1, std::numeric_limits<float>::infinity());
    expectError(cylinder.builder.model, {"POSITION", "element 4", "not finite"});
}

TEST_F(Gltf, AccessorOverrunningItsBufferViewIsRejected) {
    Cylinder cylinder = makeCylinder();
    const int positions = cylinder.accessors.positions[0];
    cylinder.builder.model.accessors[std::size_t(positions)].count += 1000;
    expectError(cylinder.builder.model, {"accessor " + std::to_string(positions), "overrun buffer view"});
    Cylinder shifted = makeCylinder();
    shifted.builder.model.bufferViews[0].byteLength += 1u << 20;
    expectError(shifted.builder.model, {"buffer"});  // tinygltf's own check, or ours
}

TEST_F(Gltf, SkinnedPrimitiveWithoutWeightsIsRejected) {
    Cylinder cylinder = makeCylinder();
    cylinder.builder.model.meshes[0].primitives[1].attributes.erase("WEIGHTS_0");
    expectError(cylinder.builder.model, {"mesh 0 primitive 1", "JOINTS_0/WEIGHTS_0"});
}

TEST_F(Gltf, BadSkinIsRejected) {
    Cylinder cylinder = makeCylinder();
    cylinder.builder.model.skins[0].joints = {0, 9};
    expectError(cylinder.builder.model, {"skin 0", "joint node 9"});
}

TEST_F(Gltf, ClipOnAMissingNodeOrWithUnorderedKeysIsRejected) {
    Cylinder cylinder = makeCylinder();
    cylinder.builder.model.animations[1].channels[0].target_node = 42;
    expectError(cylinder.builder.model, {"animation 1 'step' channel 0", "node 42"});
    Cylinder unordered = makeCylinder();
    const int input = unordered.builder.model.animations[1].samplers[0].input;
    unordered.builder.patch(input, 2, 0, 0.25f);  // keys 0, 0.5, 0.25
    expectError(unordered.builder.model, {"animation 1 'step' sampler 0 input", "keyframe 2"});
    Cylinder shortOutput = makeCylinder();
    const int output = shortOutput.builder.model.animations[0].samplers[0].output;
    shortOutput.builder.model.accessors[std::size_t(output)].count = 1;
    expectError(shortOutput.builder.model, {"animation 0 'bend' sampler 0 output", "expected 2"});
}

TEST_F(Gltf, NodeCycleIsRejected) {
    Cylinder cylinder = makeCylinder();
    cylinder.builder.model.nodes[1].children = {0};
    expectError(cylinder.builder.model, {"cycle"});
}

}  // namespace
}  // namespace psub
