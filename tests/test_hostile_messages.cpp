// Class 7 of the hostile inputs: messages that did not help. OpenSubdiv's limits are named
// with the file and element (and OpenSubdiv prints nothing on stdout); stats, compare and demo
// still do the P-S part. Numbers beyond double's range say so. A file too big for memory is
// named.
#include "test_support.h"

#include "psub/catmark.h"
#include "psub/topology.h"

#include <cmath>
#include <sstream>

namespace psub::test {
namespace {

// One face of `n` corners on a circle.
std::string bigFace(int n) {
    std::ostringstream text;
    for (int i = 0; i < n; ++i) text << "v " << std::cos(2 * M_PI * i / n) << ' ' << std::sin(2 * M_PI * i / n) << " 0\n";
    text << "# the face\nf";
    for (int i = 1; i <= n; ++i) text << ' ' << i;
    text << '\n';
    return text.str();
}

// A disk of `n` triangles around vertex 1: its valence is n.
std::string fan(int n) {
    std::ostringstream text;
    text << "v 0 0 0\n";
    for (int i = 0; i < n; ++i) text << "v " << std::cos(2 * M_PI * i / n) << ' ' << std::sin(2 * M_PI * i / n) << " 0\n";
    for (int i = 0; i < n; ++i) text << "f 1 " << i + 2 << ' ' << (i + 1) % n + 2 << '\n';
    return text.str();
}

class HostileMessages : public HostileTest {};

TEST_F(HostileMessages, AFaceBeyondOpenSubdivsLimitIsNamedAndStdoutStaysClean) {
    write("big.obj", bigFace(100000));
    refused("subdivide big.obj -o out.obj --levels 1 --scheme cc", 1,
            {"big.obj:100002: face 1: 100000 corners, beyond OpenSubdiv's limit of 65534"});
}

TEST_F(HostileMessages, AVertexBeyondOpenSubdivsLimitIsNamed) {
    write("fan.obj", fan(70000));
    refused("subdivide fan.obj -o out.obj --levels 1 --scheme cc", 1,
            {"fan.obj:1: vertex 1: in 65534 or more faces, beyond OpenSubdiv's limit"});
}

TEST_F(HostileMessages, StatsDoesTheP_SPartWhenCatmullClarkIsUnavailable) {
    write("big.obj", bigFace(100000));
    const Run run = psub("stats big.obj --levels 2");
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(contains(run.out, "level 2")) << run.out;
    EXPECT_TRUE(contains(run.out, "Catmull-Clark: unavailable for this mesh (big.obj:100002: face 1: 100000 corners"))
        << run.out;
    EXPECT_EQ(run.err, "");
}

TEST_F(HostileMessages, CompareMeasuresP_SOnlyWhenCatmullClarkIsUnavailable) {
    write("fan.obj", fan(70000));
    const Run run = psub("compare fan.obj --levels 2");
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(contains(run.out, "Catmull-Clark unavailable for this mesh")) << run.out;
    EXPECT_TRUE(contains(run.out, "area")) << run.out;
    EXPECT_TRUE(contains(run.err, "psub: warning: fan.obj:1: vertex 1: in 65534 or more faces")) << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    const Run json = psub("compare fan.obj --levels 2 --json");
    EXPECT_EQ(json.status, 0) << json.err;
    EXPECT_TRUE(contains(json.out, "\"cc\": null")) << json.out;
}

TEST_F(HostileMessages, DemoDoesTheP_SPartWhenCatmullClarkIsUnavailable) {
    write("fan.obj", fan(70000));  // (a 70000-corner face would make the demo's factorized table huge)
    fs::create_directory(work_ / "demo");
    const Run run = psub("demo --model fan.obj --levels 1 --output-dir demo", 300);
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(contains(run.out, "Catmull-Clark: unavailable for this mesh")) << run.out;
    EXPECT_TRUE(fs::exists(work_ / "demo" / "fan_ps1.obj"));
    EXPECT_FALSE(fs::exists(work_ / "demo" / "fan_cc1.obj"));
}

TEST(HostileMessagesLibrary, RefineCatmarkCarriesOpenSubdivsReasonInTheError) {
    Mesh mesh;
    mesh.positions.assign(3 * 70000, 0.0);
    mesh.faces.vertexCount = 70000;
    std::vector<Index> face(70000);
    for (Index i = 0; i < 70000; ++i) face[i] = i;
    mesh.faces.addFace(face);
    EXPECT_EQ(catmarkProblem(mesh).value_or(""), "face 1: 70000 corners, beyond OpenSubdiv's limit of 65534");
    try {
        refineCatmark(mesh.faces, mesh.positions, 1);
        ADD_FAILURE() << "OpenSubdiv refined it";
    } catch (const InputError& e) {
        EXPECT_TRUE(contains(e.what(), "OpenSubdiv could not build a Catmull-Clark refiner for this mesh: ")) << e.what();
    }
}

TEST_F(HostileMessages, NumbersBeyondDoubleRangeSaySo) {
    write("huge.obj", "v 0 0 0\nv 1e400 0 0\nv 0 1 0\nf 1 2 3\n");
    refused("subdivide huge.obj -o out.obj --levels 1", 1, {"huge.obj:2: vertex 2: number out of range: '1e400'"});
    write("neg.obj", "v 0 0 0\nv 1 0 0\nv 0 -1e999 0\nf 1 2 3\n");
    refused("subdivide neg.obj -o out.obj --levels 1", 1, {"neg.obj:3: vertex 3: number out of range: '-1e999'"});
}

TEST(HostileMessagesObj, NumbersBelowTheSmallestDenormalReadAsZero) {
    const Mesh mesh = parseObj("v 1e-400 -1e-400 4.9e-324\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj");
    EXPECT_EQ(mesh.positions[0], 0.0);
    EXPECT_EQ(mesh.positions[1], 0.0);
    EXPECT_TRUE(std::signbit(mesh.positions[1]));
    EXPECT_EQ(mesh.positions[2], 4.9e-324);  // the smallest denormal is kept
}

TEST_F(HostileMessages, AFileTooBigForMemoryIsNamed) {
    if (kSanitized) GTEST_SKIP() << "AddressSanitizer reserves more address space than the limit this test sets";
    // A sparse 2 GiB file and a 1 GiB address-space limit: reading it cannot fit.
    const std::string big = path("huge.obj");
    { std::ofstream(big) << "v 0 0 0\n"; }
    fs::resize_file(big, std::uintmax_t(2) << 30);
    const fs::path out = root_ / "stdout.txt", err = root_ / "stderr.txt";
    const std::string command = "cd '" + work_.string() + "' && ulimit -v 1048576 && '" PSUB_EXE
                                "' stats huge.obj --levels 1 >'" + out.string() + "' 2>'" + err.string() + "'";
    const int raw = std::system(command.c_str());
    ASSERT_TRUE(WIFEXITED(raw));
    EXPECT_EQ(WEXITSTATUS(raw), 1);
    const std::string message = readFile(err);
    EXPECT_TRUE(contains(message, "huge.obj")) << message;
    EXPECT_TRUE(contains(message, "does not fit in memory")) << message;
}

}  // namespace
}  // namespace psub::test
