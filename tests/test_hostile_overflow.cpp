// Class 3 of the hostile inputs: values that overflow. The policy (psub/topology.h, "Numeric
// range"): commands refuse input beyond the limit of their evaluation precision (float 1e8,
// double 1e60) naming file, line and vertex, and never write a non-finite value; the
// evaluators, which check nothing per frame, turn out-of-range control points into non-finite
// results, never into a crash or an access out of bounds (ASan/UBSan builds run these too).
#include "test_support.h"

#include "psub/evaluator.h"
#include "psub/stencils.h"
#include "psub/topology.h"
#if PSUB_HAVE_VULKAN
#include "vulkan_test_support.h"
#endif

#include <cmath>
#include <limits>

namespace psub::test {
namespace {

using HostileOverflow = HostileTest;

// --- Commands: refused at the input boundary, per precision ------------------------------

TEST_F(HostileOverflow, SubdivideOnTheCpuRefusesCoordinatesNear1e308) {
    write("big.obj", cubeObj("1e308"));
    refused("subdivide big.obj -o out.obj --levels 3", 1, {"big.obj:1: vertex 1", "coordinate x = -1e+308",
                                                           "outside +-1e+60", "double"});
}

TEST_F(HostileOverflow, SubdivideOnTheCpuAcceptsTheDoubleLimitAndWritesFiniteValues) {
    write("edge.obj", cubeObj("1e60"));
    const Run run = psub("subdivide edge.obj -o out.obj --levels 3");
    ASSERT_EQ(run.status, 0) << run.err;
    const std::string text = readFile(work_ / "out.obj");
    EXPECT_TRUE(contains(text, "e+59") || contains(text, "e+60")) << text.substr(0, 400);
    EXPECT_FALSE(contains(text, "nan") || contains(text, "inf")) << text.substr(0, 400);
}

TEST_F(HostileOverflow, SubdivideOnVulkanRefusesBeyondTheFloatLimit) {
    write("big.obj", cubeObj("1e39"));
    refused("subdivide big.obj -o out.obj --levels 2 --backend vulkan", 1,
            {"big.obj:1: vertex 1", "outside +-1e+08", "float"});
}

TEST_F(HostileOverflow, SubdivideCatmullClarkRefusesCoordinatesNear1e308) {
    write("big.obj", cubeObj("1.7e308"));
    refused("subdivide big.obj -o out.obj --levels 2 --scheme cc", 1, {"big.obj:1: vertex 1", "outside"});
}

TEST_F(HostileOverflow, RenderOf1e39CubeExitsOneAndWritesNoPicture) {
    write("big.obj", cubeObj("1e39"));
    refused("render big.obj -o cube.png --levels 2", 1, {"big.obj:1: vertex 1", "outside +-1e+08"});
}

TEST_F(HostileOverflow, RenderJustBeyondTheFloatLimitIsRefused) {
    write("big.obj", cubeObj("2e8"));
    refused("render big.obj -o cube.png --levels 2 --backend vulkan", 1, {"big.obj:1: vertex 1", "2e+08"});
}

TEST_F(HostileOverflow, PlayOf1e39CubeIsRefusedOnEveryBackend) {
    write("big.obj", cubeObj("1e39"));
    for (const char* backend : {"cpu", "vulkan"}) {
        SCOPED_TRACE(backend);
        refused(std::string("play big.obj --levels 2 --frames 3 --backend ") + backend, 1,
                {"big.obj:1: vertex 1", "outside +-1e+08", "float"});
    }
}

TEST_F(HostileOverflow, PlayNearTheFloatLimitGivesFiniteFramesOnEveryBackend) {
    // 5e7: the wave moves points beyond the rest box, and posed points are held to 1e8 too.
    write("edge.obj", cubeObj("5e7"));
    for (const char* backend : {"cpu", "vulkan"}) {
        SCOPED_TRACE(backend);
        const Run run = psub(std::string("play edge.obj --levels 3 --frames 3 --verify --backend ") + backend);
        EXPECT_EQ(run.status, 0) << run.err;
    }
}

TEST_F(HostileOverflow, PlayRefusesAFrameWhosePoseLeavesTheFloatRange) {
    // The twist keeps the size, but a glTF clip may scale: a node scale of 1e36 does it here.
    write("tet.bin", tetBin());
    std::string gltf = tetGltf("\"uri\": \"tet.bin\", ");
    gltf.replace(gltf.find("{\"mesh\": 0}"), 11, "{\"mesh\": 0, \"scale\": [1e36, 1e36, 1e36]}");
    write("scaled.gltf", gltf);
    refused("play scaled.gltf --levels 1 --frames 2", 1, {"scaled.gltf: frame 0: posed control vertex", "float"});
}

TEST_F(HostileOverflow, CompareRefusesBeyondTheDoubleLimit) {
    write("big.obj", cubeObj("1e61"));
    refused("compare big.obj --levels 2", 1, {"big.obj:1: vertex 1", "outside +-1e+60"});
}

// --- The library: the policy's functions ------------------------------------------------

TEST(HostileOverflowLibrary, CheckCoordinateRangeNamesFileLineVertexAndAxis) {
    const Mesh mesh = parseObj("v 0 0 0\nv 1 0 0\n\nv 0 3e9 0\nf 1 2 3\n", "m.obj");
    EXPECT_NO_THROW(checkCoordinateRange(mesh, Precision::Double));
    try {
        checkCoordinateRange(mesh, Precision::Float);
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()),
                  "m.obj:4: vertex 3: coordinate y = 3e+09 is outside +-1e+08, the range this command's float "
                  "evaluation refines without overflow");
    }
}

TEST(HostileOverflowLibrary, RequireFiniteNamesTheFirstNonFiniteVertex) {
    const std::vector<float> good = {1, 2, 3, 4, 5, 6};
    EXPECT_NO_THROW(requireFinite(std::span<const float>(good), "in.obj", "refined"));
    for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                       -std::numeric_limits<double>::infinity()}) {
        const std::vector<double> values = {1, 2, 3, 4, bad, 6};
        try {
            requireFinite(std::span<const double>(values), "in.obj", "refined");
            ADD_FAILURE() << "no error for " << bad;
        } catch (const InputError& e) {
            EXPECT_TRUE(contains(e.what(), "in.obj: refined vertex 2 is not finite")) << e.what();
        }
    }
}

// The scan without early exit (topology/range.cpp, allFinite) on long arrays: a NaN or an
// infinity at any place, the tail past a vector's width included, in float and double; the
// largest finite values, the smallest subnormals and zeros of both signs pass.
template <class T>
void checkEveryPlace() {
    std::vector<T> values(1003);
    for (std::size_t i = 0; i < values.size(); ++i)
        values[i] = i % 4 == 0   ? std::numeric_limits<T>::max()
                    : i % 4 == 1 ? -std::numeric_limits<T>::denorm_min()
                    : i % 4 == 2 ? T(-0.0)
                                 : T(i);
    EXPECT_NO_THROW(requireFinite(std::span<const T>(values), "in.obj", "refined"));
    for (std::size_t at : {std::size_t(0), std::size_t(17), std::size_t(500), std::size_t(1001), std::size_t(1002)})
        for (T bad : {std::numeric_limits<T>::quiet_NaN(), -std::numeric_limits<T>::infinity()}) {
            std::vector<T> copy = values;
            copy[at] = bad;
            try {
                requireFinite(std::span<const T>(copy), "in.obj", "refined");
                ADD_FAILURE() << "no error at " << at;
            } catch (const InputError& e) {
                EXPECT_TRUE(contains(e.what(), "in.obj: refined vertex " + std::to_string(at / 3 + 1) + " is not finite"))
                    << e.what();
            }
        }
}

TEST(HostileOverflowLibrary, RequireFiniteFindsANonFiniteValueAnywhere) {
    checkEveryPlace<float>();
    checkEveryPlace<double>();
}

// A long array, scanned in pieces by several threads (topology/range.cpp): a NaN or an
// infinity at either end, at both sides of a piece's border and within the last, short piece is
// found; with a second one later, the first is named.
TEST(HostileOverflowLibrary, RequireFiniteFindsANonFiniteValueInALongArray) {
    constexpr std::size_t kPiece = std::size_t(1) << 18;
    std::vector<float> values(5 * kPiece + 100);
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = float(i % 1000) - 500.0f;
    EXPECT_NO_THROW(requireFinite(std::span<const float>(values), "in.obj", "refined"));
    const std::size_t last = values.size() - 1;
    for (std::size_t at : {std::size_t(0), kPiece - 1, kPiece, 3 * kPiece + 7, last})
        for (const std::size_t also : {at, last})
            for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
                std::vector<float> copy = values;
                copy[at] = bad;
                copy[also] = -std::numeric_limits<float>::infinity();
                try {
                    requireFinite(std::span<const float>(copy), "in.obj", "refined");
                    ADD_FAILURE() << "no error at " << at;
                } catch (const InputError& e) {
                    EXPECT_TRUE(contains(e.what(), "in.obj: refined vertex " + std::to_string(at / 3 + 1) + " is not finite"))
                        << e.what() << " (at " << at << ")";
                }
            }
}

// --- The library: every evaluator on out-of-range control points --------------------------

struct Cube {
    Mesh mesh = parseObj(cubeObj("1"), "cube.obj");
    CheckedMesh checked = checkMesh(mesh);
    Refinement r = refine(mesh, checked.connectivity, [] {
        RefineOptions options;
        options.levels = 3;
        options.factorized = true;
        return options;
    }());
};

// Control points of the cube with vertex 0 set to `bad` on every axis.
template <class T>
std::vector<T> poisoned(const Cube& cube, double bad) {
    std::vector<T> control(cube.mesh.positions.begin(), cube.mesh.positions.end());
    for (int axis = 0; axis < 3; ++axis) control[std::size_t(axis)] = T(bad);
    return control;
}

// The documented result: every refined value and normal is finite where the bad point does
// not reach, and somewhere the bad point reaches, a position is not finite or a normal is not
// a unit vector (NaN, infinite or zero).
template <class T>
void expectDocumentedResult(std::span<const T> refined, std::span<const T> normals) {
    bool broken = false;
    for (T v : refined) broken = broken || !std::isfinite(v);
    for (std::size_t i = 0; i + 2 < normals.size(); i += 3) {
        const double length = std::hypot(double(normals[i]), double(normals[i + 1]), double(normals[i + 2]));
        broken = broken || !(std::abs(length - 1) < 1e-3);
    }
    EXPECT_TRUE(broken) << "out-of-range control points left every result finite and unit";
}

const double kBadValues[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity(), 1e38, 1e308};

template <class T>
void runCpu(TableForm form) {
    const Cube cube;
    for (double bad : kBadValues) {
        if (std::is_same_v<T, double> && bad == 1e38) continue;  // finite and harmless in double
        SCOPED_TRACE(bad);
        CpuEvaluator<T> evaluator(cube.r.perLevel, cube.r.factorized, cube.r.surface, form);
        const std::vector<T> control = poisoned<T>(cube, bad);
        std::vector<T> refined(3 * std::size_t(evaluator.refinedCount())), normals(refined.size());
        evaluator.evaluate(control, refined);
        evaluator.normals(refined, normals);
        expectDocumentedResult<T>(refined, normals);
    }
}

TEST(HostileOverflowLibrary, CpuFloatPerLevel) { runCpu<float>(TableForm::PerLevel); }
TEST(HostileOverflowLibrary, CpuFloatFactorized) { runCpu<float>(TableForm::Factorized); }
TEST(HostileOverflowLibrary, CpuDoublePerLevel) { runCpu<double>(TableForm::PerLevel); }
TEST(HostileOverflowLibrary, CpuDoubleFactorized) { runCpu<double>(TableForm::Factorized); }

#if PSUB_HAVE_VULKAN
TEST(HostileOverflowLibrary, VulkanPerLevelAndFactorized) {
    std::unique_ptr<VulkanContext> context;
    test::makeContextOrSkip(context, VulkanOptions{});
    if (!context) return;
    const Cube cube;
    for (TableForm form : {TableForm::PerLevel, TableForm::Factorized})
        for (double bad : kBadValues) {
            SCOPED_TRACE(bad);
            VulkanEvaluator evaluator(*context, cube.r.perLevel, cube.r.factorized, cube.r.surface, form);
            const std::vector<float> control = poisoned<float>(cube, bad);
            std::vector<float> refined(3 * std::size_t(evaluator.refinedCount())), normals(refined.size());
            evaluator.evaluate(control, refined, normals);
            expectDocumentedResult<float>(refined, normals);
        }
}
#endif

}  // namespace
}  // namespace psub::test
