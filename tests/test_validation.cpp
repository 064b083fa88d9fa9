// docs/scheme.md, "Bad input": every defect is rejected with a message naming file, line and element;
// non-manifold vertices and unused vertices are accepted with warnings; the psub program
// exits 1 with one error line and leaves no output behind.
#include "psub/topology.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <fcntl.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace psub {
namespace {

namespace fs = std::filesystem;
using test::inputErrorOf;

using test::contains;

std::string badPath(const std::string& name) { return std::string(PSUB_TEST_DATA "/bad/") + name + ".obj"; }

// readObj + checkMesh, as the program loads a file; the InputError message, or a failure.
std::string loadError(const std::string& path) {
    try {
        checkMesh(readObj(path));
    } catch (const InputError& error) {
        return error.what();
    }
    ADD_FAILURE() << path << " was accepted";
    return "(accepted)";
}

struct Loaded {
    Mesh mesh;
    CheckedMesh checked;
    std::vector<std::string> warnings;  // reader's and checker's
};

Loaded loadChecked(const std::string& path) {
    Loaded loaded;
    loaded.mesh = readObj(path, &loaded.warnings);
    loaded.checked = checkMesh(loaded.mesh);
    loaded.warnings.insert(loaded.warnings.end(), loaded.checked.warnings.begin(),
                           loaded.checked.warnings.end());
    return loaded;
}

// One defective file: what its message must contain besides the path. `line` 0: no line.
struct BadCase {
    const char* name;
    int line;
    std::vector<std::string> needles;
};

const std::vector<BadCase>& badCases() {
    static const std::vector<BadCase> cases = {
        {"index_out_of_range", 9, {"face 4", "vertex index 5", "out of range"}},
        {"index_zero", 5, {"face 1", "index 0"}},
        {"negative_index_out_of_range", 5, {"face 1", "-4", "points before"}},
        {"nonmanifold_edge", 9, {"face 3", "edge 1-2", "shared by 3 faces", "non-manifold edge"}},
        {"inconsistent_orientation", 9, {"face 2", "edge 2-5", "inconsistent orientation"}},
        {"nan_coordinate", 4, {"vertex 3", "coordinate y", "not finite"}},
        {"inf_coordinate", 3, {"vertex 2", "coordinate x", "not finite"}},
        {"repeated_vertex", 6, {"face 1", "vertex 2", "twice"}},
        {"too_few_corners", 6, {"face 2", "2 corners"}},
        {"empty", 0, {"empty mesh"}},
        {"no_geometry", 0, {"empty mesh"}},
    };
    return cases;
}

TEST(ValidationBadFiles, EachDefectIsRejectedNamingFileLineAndDefect) {
    for (const BadCase& bad : badCases()) {
        SCOPED_TRACE(bad.name);
        const std::string path = badPath(bad.name);
        const std::string message = loadError(path);
        EXPECT_TRUE(contains(message, path)) << message;
        if (bad.line > 0) {
            EXPECT_TRUE(contains(message, path + ":" + std::to_string(bad.line) + ":")) << message;
        }
        for (const std::string& needle : bad.needles)
            EXPECT_TRUE(contains(message, needle)) << "missing '" << needle << "' in: " << message;
        EXPECT_FALSE(contains(message, "\n")) << message;
    }
}

TEST(ValidationBadFiles, MessagesOfDifferentDefectsDiffer) {
    // Compared without the path; the two empty files are the same defect.
    std::map<std::string, std::string> byMessage;  // message without path -> file
    for (const BadCase& bad : badCases()) {
        if (std::string(bad.name) == "no_geometry") continue;
        const std::string path = badPath(bad.name);
        std::string message = loadError(path);
        for (std::size_t at; (at = message.find(path)) != std::string::npos;)
            message.replace(at, path.size(), "FILE");
        const auto [it, inserted] = byMessage.emplace(message, bad.name);
        EXPECT_TRUE(inserted) << bad.name << " and " << it->second << " both say: " << message;
    }
}

TEST(ValidationBadFiles, EmptyAndCommentOnlyFilesAreBothEmptyMeshes) {
    for (const char* name : {"empty", "no_geometry"}) {
        const std::string message = loadError(badPath(name));
        EXPECT_TRUE(contains(message, "no vertices and no faces")) << message;
    }
}

TEST(ValidationBadFiles, VerticesWithoutFacesAreAnEmptyMesh) {
    Mesh mesh = parseObj("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "points.obj");
    const std::string message = inputErrorOf([&] { checkMesh(mesh); });
    EXPECT_TRUE(contains(message, "points.obj")) << message;
    EXPECT_TRUE(contains(message, "empty mesh")) << message;
    EXPECT_TRUE(contains(message, "3 vertices")) << message;
}

TEST(ValidationBadFiles, FanOfThreeFacesOnOneEdgeIsRejected) {
    const std::string path = PSUB_TEST_DATA "/osd-shapes/catmark_fan.obj";
    const std::string message = loadError(path);
    EXPECT_TRUE(contains(message, path + ":")) << message;
    // catmark_fan.obj: each of the edges 8-9 to 11-12 has three quads, one in the plane y = 0,
    // one rising to y = 0.5 and one falling to y = -0.5.
    EXPECT_TRUE(contains(message, "shared by 3 faces")) << message;
    EXPECT_TRUE(contains(message, "non-manifold edge")) << message;
}

// ---------------------------------------------------------------------------------------
// Accepted with warnings

std::size_t countKind(const Connectivity& c, VertexKind kind) {
    return std::size_t(std::count(c.kind.begin(), c.kind.end(), kind));
}

TEST(ValidationAccepted, BowtieVertexIsNonManifoldWithAWarningNamingIt) {
    const std::string path = PSUB_TEST_DATA "/bowtie.obj";
    const Loaded bowtie = loadChecked(path);
    const Connectivity& c = bowtie.checked.connectivity;
    EXPECT_EQ(c.kind[0], VertexKind::NonManifold);
    EXPECT_EQ(countKind(c, VertexKind::NonManifold), 1u);
    // bowtie.obj: two triangles meeting at vertex 1 (line 2, after the comment); the other 4
    // vertices are on the triangles' open edges.
    EXPECT_EQ(countKind(c, VertexKind::Boundary), 4u);
    ASSERT_EQ(bowtie.warnings.size(), 1u);
    const std::string& warning = bowtie.warnings[0];
    EXPECT_TRUE(contains(warning, path + ":2: vertex 1 ")) << warning;
    EXPECT_TRUE(contains(warning, "non-manifold")) << warning;
}

TEST(ValidationAccepted, CowVertex254IsNonManifoldWithAWarningGivingItsLine) {
    const std::string path = PSUB_DATA "/cow.obj";
    const Loaded cow = loadChecked(path);
    const Connectivity& c = cow.checked.connectivity;
    // data/cow.obj counted: 2903 `v` and 5804 `f` lines; its first `v` is line 11, so vertex
    // 254 (index 253) is line 264. That vertex 254 is the one non-manifold vertex is a
    // regression value: found by checkMesh, as docs/scheme.md describes (the tail touches the body).
    EXPECT_EQ(cow.mesh.faces.vertexCount, 2903u);
    EXPECT_EQ(cow.mesh.faces.faceCount(), 5804u);
    EXPECT_EQ(c.kind[253], VertexKind::NonManifold);
    EXPECT_EQ(countKind(c, VertexKind::NonManifold), 1u);
    ASSERT_EQ(cow.warnings.size(), 1u);
    const std::string& warning = cow.warnings[0];
    EXPECT_TRUE(contains(warning, path + ":264: vertex 254 ")) << warning;
    EXPECT_TRUE(contains(warning, "non-manifold")) << warning;
}

TEST(ValidationAccepted, UnusedVertexIsKeptWithOneWarning) {
    const std::string path = PSUB_TEST_DATA "/osd-shapes/catmark_nonman_verts.obj";
    const Loaded loaded = loadChecked(path);
    const Connectivity& c = loaded.checked.connectivity;
    EXPECT_EQ(countKind(c, VertexKind::Unused), 1u);
    EXPECT_EQ(c.kind.size(), loaded.mesh.faces.vertexCount);
    const auto unusedWarnings = std::count_if(loaded.warnings.begin(), loaded.warnings.end(),
                                              [](const std::string& w) { return contains(w, "used by no face"); });
    ASSERT_EQ(unusedWarnings, 1);
    const std::string& warning = *std::find_if(loaded.warnings.begin(), loaded.warnings.end(),
                                               [](const std::string& w) { return contains(w, "used by no face"); });
    EXPECT_TRUE(contains(warning, "1 vertex is used by no face")) << warning;
    EXPECT_TRUE(contains(warning, path)) << warning;
}

TEST(ValidationAccepted, UnusedVerticesAreCountedInOneWarningNamingTheFirst) {
    Mesh mesh = parseObj("v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 8 8 8\nf 2 3 4\n", "spare.obj");
    const CheckedMesh checked = checkMesh(mesh);
    ASSERT_EQ(checked.warnings.size(), 1u);
    EXPECT_TRUE(contains(checked.warnings[0], "2 vertices are used by no face")) << checked.warnings[0];
    EXPECT_TRUE(contains(checked.warnings[0], "spare.obj:1: vertex 1")) << checked.warnings[0];
    EXPECT_EQ(checked.connectivity.kind[0], VertexKind::Unused);
    EXPECT_EQ(checked.connectivity.kind[4], VertexKind::Unused);
}

TEST(ValidationAccepted, CleanClosedMeshHasNoWarnings) {
    const Loaded cube = loadChecked(PSUB_DATA "/cube.obj");
    EXPECT_TRUE(cube.warnings.empty()) << cube.warnings.front();
    // cube.obj is closed: all its 8 vertices are interior.
    EXPECT_EQ(countKind(cube.checked.connectivity, VertexKind::Interior), 8u);
}

// ---------------------------------------------------------------------------------------
// In-memory meshes: no file, but the element

Mesh squareMesh() {
    Mesh mesh;
    mesh.faces.vertexCount = 4;
    mesh.faces.addFace(std::vector<Index>{0, 1, 2});
    mesh.faces.addFace(std::vector<Index>{0, 2, 3});
    mesh.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    return mesh;
}

TEST(ValidationInMemory, ValidSquareIsAcceptedWithoutWarnings) {
    const CheckedMesh checked = checkMesh(squareMesh());
    EXPECT_TRUE(checked.warnings.empty());
    // The square's 4 sides and the diagonal 0-2.
    EXPECT_EQ(checked.connectivity.edgeCount(), 5u);
}

TEST(ValidationInMemory, DefectsNameTheElementAndNoFile) {
    struct Case {
        const char* what;
        Mesh mesh;
        std::string start;  // the message starts with the element
        std::string needle;
    };
    // Elements are named from 1: positions[4] is vertex 2's y, positions[9] vertex 4's x,
    // verts[4] is in face 2, verts[2] in face 1, and an added face is face 3.
    std::vector<Case> cases;
    {
        Mesh m = squareMesh();
        m.positions[4] = std::numeric_limits<double>::quiet_NaN();
        cases.push_back({"nan", m, "vertex 2", "not finite"});
    }
    {
        Mesh m = squareMesh();
        m.positions[9] = -std::numeric_limits<double>::infinity();
        cases.push_back({"inf", m, "vertex 4", "not finite"});
    }
    {
        Mesh m = squareMesh();
        m.faces.verts[4] = 7;
        cases.push_back({"out of range", m, "face 2", "out of range"});
    }
    {
        Mesh m = squareMesh();
        m.faces.verts[2] = 1;
        cases.push_back({"repeated", m, "face 1", "twice"});
    }
    {
        Mesh m = squareMesh();
        m.faces.addFace(std::vector<Index>{1, 3});
        cases.push_back({"two corners", m, "face 3", "corners"});
    }
    {
        Mesh m = squareMesh();
        m.faces.addFace(std::vector<Index>{0, 1, 3});  // 0->1 again
        cases.push_back({"orientation", m, "face 3", "inconsistent orientation"});
    }
    {
        Mesh m = squareMesh();
        m.faces.addFace(std::vector<Index>{0, 2, 1});  // edge 1-3 a third time
        cases.push_back({"fin", m, "face 3", "non-manifold edge"});
    }
    for (const Case& c : cases) {
        SCOPED_TRACE(c.what);
        const std::string message = inputErrorOf([&] { checkMesh(c.mesh); });
        EXPECT_EQ(message.rfind(c.start, 0), 0u) << message;
        EXPECT_TRUE(contains(message, c.needle)) << message;
        EXPECT_FALSE(contains(message, ".obj")) << message;
    }
}

TEST(ValidationInMemory, EmptyMeshIsRejected) {
    const std::string message = inputErrorOf([] { checkMesh(Mesh{}); });
    EXPECT_TRUE(contains(message, "empty mesh")) << message;
}

TEST(ValidationInMemory, PositionsOfTheWrongSizeAreRejected) {
    // 4 vertices need 12 coordinates: one short, one and three over, none.
    for (std::size_t size : {std::size_t(11), std::size_t(13), std::size_t(15), std::size_t(0)}) {
        SCOPED_TRACE(size);
        Mesh mesh = squareMesh();
        mesh.positions.resize(size, 0.5);
        const std::string message = inputErrorOf([&] { checkMesh(mesh); });
        EXPECT_TRUE(contains(message, std::to_string(size) + " coordinates for 4 vertices")) << message;
    }
}

TEST(ValidationInMemory, ValidateFacesNamesThePathWhenThereAreNoLines) {
    Faces faces;
    faces.vertexCount = 3;
    faces.addFace(std::vector<Index>{0, 1, 1});
    Source source;
    source.path = "made.obj";
    const std::string message = inputErrorOf([&] { validateFaces(faces, source); });
    EXPECT_EQ(message.rfind("made.obj: face 1 ", 0), 0u) << message;
    EXPECT_TRUE(contains(message, "twice")) << message;
}

TEST(ValidationInMemory, BuildConnectivityNamesTheLineThroughTheSource) {
    Faces faces;
    faces.vertexCount = 4;
    faces.addFace(std::vector<Index>{0, 1, 2});
    faces.addFace(std::vector<Index>{0, 1, 3});
    Source source;
    source.path = "two.obj";
    source.faceLine = {10, 20};
    const std::string message = inputErrorOf([&] { buildConnectivity(faces, source); });
    // Face 2 (faceLine 20) runs 0->1 again: edge 1-2 counted from 1.
    EXPECT_EQ(message.rfind("two.obj:20: face 2", 0), 0u) << message;
    EXPECT_TRUE(contains(message, "edge 1-2")) << message;
    EXPECT_TRUE(contains(message, "inconsistent orientation")) << message;
}

// ---------------------------------------------------------------------------------------
// The psub program

const auto readText = test::readFile;
const auto entriesOf = test::namesIn;
using test::linesOf;

class CliTest : public testing::Test {
protected:
    void SetUp() override {
        std::string pattern = (fs::path(testing::TempDir()) / "psub-cli-XXXXXX").string();
        ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
        root_ = pattern;
        out_ = root_ / "out";
        fs::create_directory(out_);
    }
    void TearDown() override {
        std::error_code ignored;
        fs::remove_all(root_, ignored);
    }

    using Result = test::PsubRun;

    // Runs psub with `args` (shell words); stdout and stderr go to files outside out_.
    Result psub(const std::string& args) { return test::runPsub(args); }

    std::string output() const { return (out_ / "out.obj").string(); }

    fs::path root_, out_;
};

TEST_F(CliTest, EveryBadFileExitsOneWithOneErrorLineAndNoOutput) {
    for (const BadCase& bad : badCases()) {
        SCOPED_TRACE(bad.name);
        const std::string path = badPath(bad.name);
        const Result r = psub("subdivide '" + path + "' -o '" + output() + "' --levels 2");
        EXPECT_EQ(r.status, 1);
        const std::vector<std::string> lines = linesOf(r.err);
        ASSERT_EQ(lines.size(), 1u) << r.err;
        EXPECT_EQ(lines[0].rfind("psub: error: ", 0), 0u) << lines[0];
        EXPECT_TRUE(contains(lines[0], path)) << lines[0];
        EXPECT_TRUE(contains(lines[0], bad.needles.back())) << lines[0];
        EXPECT_TRUE(entriesOf(out_).empty()) << "left behind: " << entriesOf(out_).front();
    }
}

TEST_F(CliTest, FullDiskLeavesNoPartialFileAndExitsOne) {
    // A 64 KiB file-size limit stands in for a full disk: the refined cow is megabytes.
    // (std::system runs /bin/sh; dash's ulimit -f counts 512-byte blocks: 128 x 512 B = 64 KiB.)
    const fs::path outFile = root_ / "stdout.txt", errFile = root_ / "stderr.txt";
    const std::string command = "ulimit -f 128; '" PSUB_EXE "' subdivide '" + std::string(PSUB_DATA) +
                                "/cow.obj' -o '" + output() + "' --levels 2 >'" + outFile.string() +
                                "' 2>'" + errFile.string() + "' </dev/null";
    const int raw = std::system(command.c_str());
    ASSERT_TRUE(raw != -1 && WIFEXITED(raw)) << command;
    EXPECT_EQ(WEXITSTATUS(raw), 1);
    EXPECT_TRUE(contains(readText(errFile), "cannot write")) << readText(errFile);
    EXPECT_TRUE(entriesOf(out_).empty()) << "left behind: " << entriesOf(out_).front();
}

TEST_F(CliTest, BadInputLeavesAnExistingOutputFileUntouched) {
    std::ofstream(output()) << "previous result\n";
    const Result r = psub("subdivide '" + badPath("nonmanifold_edge") + "' -o '" + output() + "' --levels 2");
    EXPECT_EQ(r.status, 1);
    EXPECT_EQ(readText(output()), "previous result\n");
    EXPECT_EQ(entriesOf(out_), std::vector<std::string>{"out.obj"});
}

TEST_F(CliTest, EdgeFanFileExitsOneWithNoOutput) {
    const Result r = psub("subdivide '" PSUB_TEST_DATA "/osd-shapes/catmark_fan.obj' -o '" +
                          output() + "' --levels 1");
    EXPECT_EQ(r.status, 1);
    EXPECT_EQ(r.err.rfind("psub: error: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, "non-manifold edge")) << r.err;
    EXPECT_TRUE(entriesOf(out_).empty());
}

TEST_F(CliTest, OutputDirectoryThatCannotExistExitsOneWithOneErrorLine) {
    const fs::path plain = root_ / "plain";
    std::ofstream(plain) << "a file";
    const Result r = psub("subdivide '" PSUB_DATA "/cube.obj' -o '" + (plain / "out.obj").string() +
                          "' --levels 1");
    EXPECT_EQ(r.status, 1);
    const std::vector<std::string> lines = linesOf(r.err);
    ASSERT_EQ(lines.size(), 1u) << r.err;
    EXPECT_EQ(lines[0].rfind("psub: error: ", 0), 0u) << lines[0];
    EXPECT_EQ(readText(plain), "a file");
}

TEST_F(CliTest, LevelCountBeyondMemoryExitsOneBeforeWriting) {
    const Result r = psub("subdivide '" PSUB_DATA "/cow.obj' -o '" + output() + "' --levels 30");
    EXPECT_EQ(r.status, 1);
    const std::vector<std::string> lines = linesOf(r.err);
    ASSERT_FALSE(lines.empty());
    EXPECT_EQ(lines.back().rfind("psub: error: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(lines.back(), "cow.obj")) << r.err;
    // Regression value: measured with `psub subdivide data/cow.obj -o out.obj --levels 30`,
    // 2026-12-03: "about 3.0 PiB" (cli/memory_guard.cpp's estimate; faces double each step).
    EXPECT_TRUE(contains(lines.back(), "PiB")) << r.err;  // the estimate: thousands of terabytes
    EXPECT_TRUE(contains(lines.back(), "is the most that fits")) << r.err;
    EXPECT_TRUE(entriesOf(out_).empty());
}

TEST_F(CliTest, MaxMemoryNamesTheDeepestLevelThatFits) {
    const Result r = psub("subdivide '" PSUB_DATA "/cow.obj' -o '" + output() + "' --levels 6 --max-memory 100M");
    EXPECT_EQ(r.status, 1);
    // Regression values: measured with `psub subdivide data/cow.obj -o out.obj --levels L
    // --max-memory 1K` (L = 4, 5, 6), 2026-12-03, with huge pages: estimates 68.1 MiB (L = 4),
    // 120.7 MiB (5), 225.9 MiB (6) (the peaks measured: 60.5, 110.0, 198.4 MiB); 100M is 100
    // MiB (powers of 1024, cli/main.cpp), so 4 fits and 5 does not.
    EXPECT_TRUE(contains(r.err, "about 225.9 MiB")) << r.err;
    EXPECT_TRUE(contains(r.err, "limit 100.0 MiB")) << r.err;
    EXPECT_TRUE(contains(r.err, "--levels 4 is the most that fits")) << r.err;
    EXPECT_TRUE(entriesOf(out_).empty());
    EXPECT_EQ(psub("subdivide '" PSUB_DATA "/cow.obj' -o '" + output() + "' --levels 2 --max-memory 100M").status, 0);
}

// The memory guard's estimate bounds the peak it guards: `psub subdivide` of the cow at 4 and
// 7 steps stays within the estimate the guard prints for it (measured 2026-12-03: peaks 56.9
// and 345 MiB, estimates 63.4 and 398.1 MiB). The peak is the child's own (wait4's maximum
// resident size). Under AddressSanitizer the resident size measures its shadow memory and
// quarantine, not the program: the bound is checked in the plain build only.
TEST_F(CliTest, MemoryGuardEstimateBoundsThePeak) {
    for (const int levels : {4, 7}) {
        SCOPED_TRACE(levels);
        const std::string cow = std::string(PSUB_DATA) + "/cow.obj", lv = std::to_string(levels);
        const Result refused = psub("subdivide '" + cow + "' -o '" + output() + "' --levels " + lv + " --max-memory 1K");
        ASSERT_EQ(refused.status, 1) << refused.err;
        const std::size_t at = refused.err.find("about ");
        ASSERT_NE(at, std::string::npos) << refused.err;
        std::size_t used = 0;
        const double number = std::stod(refused.err.substr(at + 6), &used);
        const std::string unit = refused.err.substr(at + 6 + used + 1, 3);
        ASSERT_TRUE(unit == "MiB" || unit == "GiB") << refused.err;
        const double estimateKiB = number * (unit == "GiB" ? 1024.0 * 1024.0 : 1024.0);

        const pid_t child = ::fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
            const int null = ::open("/dev/null", O_WRONLY);  // only async-signal-safe calls after fork
            ::dup2(null, 1);
            ::dup2(null, 2);
            ::execl(PSUB_EXE, "psub", "subdivide", cow.c_str(), "-o", output().c_str(), "--levels", lv.c_str(),
                    static_cast<char*>(nullptr));
            ::_exit(127);
        }
        int status = 0;
        rusage usage{};
        ASSERT_EQ(::wait4(child, &status, 0, &usage), child);
        ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "psub subdivide --levels " << lv << " failed";
        EXPECT_GT(usage.ru_maxrss, 0);
        if (!test::kSanitized) {
            EXPECT_LE(double(usage.ru_maxrss), estimateKiB)
                << "peak " << usage.ru_maxrss << " KiB, estimate " << estimateKiB << " KiB";
        }
        fs::remove(output());
    }
}

TEST_F(CliTest, MissingRequiredOptionExitsTwo) {
    EXPECT_EQ(psub("subdivide '" PSUB_DATA "/cube.obj' --levels 1").status, 2);  // no -o
    EXPECT_EQ(psub("subdivide -o '" + output() + "'").status, 2);               // no input
    EXPECT_TRUE(entriesOf(out_).empty());
}

TEST_F(CliTest, HelpExitsZero) {
    const Result r = psub("--help");
    EXPECT_EQ(r.status, 0);
    EXPECT_TRUE(contains(r.out + r.err, "subdivide")) << r.out << r.err;
}

TEST_F(CliTest, CowIsSubdividedWithANonManifoldVertexWarning) {
    const Result r = psub("subdivide '" PSUB_DATA "/cow.obj' -o '" + output() + "' --levels 1");
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(r.err, "psub: warning: ")) << r.err;
    EXPECT_TRUE(contains(r.err, "cow.obj:264: vertex 254 ")) << r.err;
    EXPECT_TRUE(contains(r.err, "non-manifold")) << r.err;
    EXPECT_FALSE(contains(r.err, "error")) << r.err;
    EXPECT_EQ(entriesOf(out_), std::vector<std::string>{"out.obj"});
    const Mesh result = readObj(output());
    EXPECT_GT(result.faces.faceCount(), 5804u);
}

TEST_F(CliTest, BowtieIsSubdividedWithANonManifoldVertexWarning) {
    const Result r = psub("subdivide '" PSUB_TEST_DATA "/bowtie.obj' -o '" + output() + "' --levels 2");
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(r.err, "psub: warning: ")) << r.err;
    EXPECT_TRUE(contains(r.err, "bowtie.obj:2: vertex 1 ")) << r.err;
    EXPECT_TRUE(contains(r.err, "non-manifold")) << r.err;
    EXPECT_EQ(entriesOf(out_), std::vector<std::string>{"out.obj"});
    const Mesh result = readObj(output());
    EXPECT_EQ(result.positions[0], 0.0);  // the pinch vertex is retained in place
    EXPECT_EQ(result.positions[1], 0.0);
    EXPECT_EQ(result.positions[2], 0.0);
}

}  // namespace
}  // namespace psub
