// OBJ reading (every face-entry form, ignored statements, line-accurate errors, truncated
// input) and writing (formatObj round trip; tests/test_output.cpp tests the file writing).
#include "psub/topology.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include <stdlib.h>
#include <sys/stat.h>
#include <sys/types.h>

namespace psub {
namespace {

namespace fs = std::filesystem;
using test::inputErrorOf;

using test::contains;

Mesh parse(std::string_view text, std::vector<std::string>* warnings = nullptr) {
    return parseObj(text, "test.obj", warnings);
}

std::string parseError(std::string_view text) {
    return inputErrorOf([&] { parse(text); });
}

std::vector<std::vector<Index>> facesOf(const Faces& faces) {
    std::vector<std::vector<Index>> out;
    for (Index f = 0; f < faces.faceCount(); ++f)
        out.emplace_back(faces.face(f).begin(), faces.face(f).end());
    return out;
}

const auto readText = test::readFile;
const auto writeText = test::writeFile;
using TempDir = test::ScratchDir;

// Four vertices and two triangles [1 2 3] [1 3 4] (0-based below).
constexpr const char* kSquareVertices =
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 1 1 0\n"
    "v 0 1 0\n";
const std::vector<double> kSquarePositions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
const std::vector<std::vector<Index>> kSquareFaces = {{0, 1, 2}, {0, 2, 3}};

void expectSquare(const Mesh& mesh) {
    EXPECT_EQ(mesh.faces.vertexCount, 4u);
    EXPECT_EQ(mesh.positions, kSquarePositions);
    EXPECT_EQ(facesOf(mesh.faces), kSquareFaces);
}

// ---------------------------------------------------------------------------------------
// Face entries and ignored content

TEST(ObjReader, EveryFaceEntryFormGivesTheSameMesh) {
    const char* faceForms[] = {
        "f 1 2 3\nf 1 3 4\n",                          // i
        "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",              // i/t
        "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n",  // i/t/n
        "f 1//1 2//1 3//1\nf 1//1 3//1 4//1\n",        // i//n
        "f -4 -3 -2\nf -4 -2 -1\n",                    // relative
        "f -4/1 2//7 -2/3/1\nf 1 -2//2 4/4/4\n",       // mixed in one face
    };
    for (const char* faces : faceForms) {
        SCOPED_TRACE(faces);
        expectSquare(parse(std::string(kSquareVertices) + faces));
    }
}

TEST(ObjReader, RelativeIndicesCountOnlyTheVerticesReadSoFar) {
    const Mesh mesh = parse(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\n"
        "f -3 -2 -1\n"  // 1 2 3
        "v 0 1 0\n"
        "f -4 -2 -1\n");  // 1 3 4
    expectSquare(mesh);
}

TEST(ObjReader, FaceRecordsItsSourceLineAndVertexRecordsItsLine) {
    const Mesh mesh = parse("# header\n\nv 0 0 0\nv 1 0 0\n\nv 1 1 0\nv 0 1 0\nf 1 2 3\n# x\nf 1 3 4\n");
    EXPECT_EQ(mesh.source.path, "test.obj");
    // Lines count from 1, comment and blank lines included.
    EXPECT_EQ(mesh.source.vertexLine, (std::vector<std::uint32_t>{3, 4, 6, 7}));
    EXPECT_EQ(mesh.source.faceLine, (std::vector<std::uint32_t>{8, 10}));
}

TEST(ObjReader, IgnoresKnownNonGeometryStatementsCommentsAndBlankLinesWithoutWarnings) {
    const std::string text =
        "# a comment\n"
        "mtllib scene.mtl\n"
        "o object\n"
        "\n"
        "   \n"
        "v 0 0 0\n"
        "vt 0.5 0.5\n"
        "v 1 0 0\n"
        "vn 0 0 1\n"
        "vp 0.2 0.3\n"
        "v 1 1 0\n"
        "   # an indented comment\n"
        "v 0 1 0\n"
        "g group\n"
        "s 1\n"
        "s off\n"
        "usemtl red\n"
        "f 1 2 3\n"
        "l 1 2\n"
        "f 1 3 4\n";
    std::vector<std::string> warnings;
    const Mesh mesh = parse(text, &warnings);
    expectSquare(mesh);
    EXPECT_TRUE(warnings.empty()) << warnings.front();
}

TEST(ObjReader, AcceptsCrlfLineEnds) {
    const Mesh mesh = parse("v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nf 1 2 3\r\nf 1/1 3//2 4\r\n");
    expectSquare(mesh);
}

TEST(ObjReader, JoinsBackslashContinuationLinesOfFacesAndVertices) {
    const Mesh mesh = parse(
        "v 0 0 0\n"
        "v 1 \\\n"
        "  0 \\\n"
        "  0\n"
        "v 1 1 0\r\n"
        "v 0 1 0\n"
        "f 1 2 \\\r\n"
        "3\n"
        "f 1 \\\n"
        "3 4 \\");  // a continuation on the last line ends the statement
    expectSquare(mesh);
    // A continued statement has the line it starts on; its continuation lines still count.
    EXPECT_EQ(mesh.source.vertexLine, (std::vector<std::uint32_t>{1, 2, 5, 6}));
    EXPECT_EQ(mesh.source.faceLine, (std::vector<std::uint32_t>{7, 9}));
}

TEST(ObjReader, ContinuedStatementKeepsLaterLineNumbersRight) {
    const std::string message = parseError(
        "v 0 \\\n"
        "0 0\n"
        "v 1 0 0\n"
        "v 0 1 0\n"
        "f 1 2 3\n"
        "v oops 0 0\n");
    // The first statement spans lines 1-2, so the bad vertex is on line 6.
    EXPECT_TRUE(contains(message, "test.obj:6:")) << message;
}

TEST(ObjReader, ErrorInsideAContinuedStatementNamesItsFirstLine) {
    const std::string message = parseError("v 0 0 0\nv 1 \\\nx 0\n");
    EXPECT_TRUE(contains(message, "test.obj:2:")) << message;
}

TEST(ObjReader, AcceptsTabsBetweenTokens) {
    const Mesh mesh = parse("v\t0\t0 0\nv 1\t\t0\t0\n\tv 1 1 0\nv 0 1 0\t\nf\t1\t2\t3\nf 1 3 4\n");
    expectSquare(mesh);
}

TEST(ObjReader, IgnoresWCoordinateAndVertexColours) {
    const Mesh mesh = parse(
        "v 0 0 0 1.0\n"
        "v 1 0 0 0.5 0.25 0.125\n"
        "v 1 1 0 0.1 0.2 0.3 1\n"
        "v 0 1 0\n"
        "f 1 2 3\nf 1 3 4\n");
    expectSquare(mesh);
}

TEST(ObjReader, AcceptsForwardReferencesWithinRange) {
    const Mesh mesh = parse(std::string("f 1 2 3\nf 1 3 4\n") + kSquareVertices);
    expectSquare(mesh);
}

TEST(ObjReader, ParsesSignedAndExponentNumbers) {
    const Mesh mesh = parse("v +1.5 -2e-3 3E2\nv .5 -0 1e+1\nv 7 8 9\nf 1 2 3\n");
    EXPECT_EQ(mesh.positions, (std::vector<double>{1.5, -2e-3, 300, 0.5, -0.0, 10, 7, 8, 9}));
}

// ---------------------------------------------------------------------------------------
// Errors name the file and line

TEST(ObjReader, MalformedCoordinateNamesFileAndLine) {
    const char* bad[] = {"v 1 x 3\n", "v 1 2\n", "v 1 2 3x\n", "v 1 2 1e999\n", "v\n", "v 1,5 2 3\n"};
    for (const char* line : bad) {
        SCOPED_TRACE(line);
        const std::string message = parseError(std::string("# c\nv 0 0 0\n\n") + line);
        EXPECT_TRUE(contains(message, "test.obj:4:")) << message;
        EXPECT_TRUE(contains(message, "vertex 2")) << message;
    }
}

TEST(ObjReader, MalformedFaceEntryNamesFileAndLine) {
    const char* bad[] = {"f 1 2 x\n", "f 1 2 3a\n", "f 1 /2 3\n", "f 1 2 1.5\n",
                         "f 1 2 99999999999999999999999\n"};
    for (const char* line : bad) {
        SCOPED_TRACE(line);
        const std::string message = parseError(std::string(kSquareVertices) + "f 1 2 3\n" + line);
        // 4 vertex lines and one face before it: line 6, face 2.
        EXPECT_TRUE(contains(message, "test.obj:6:")) << message;
        EXPECT_TRUE(contains(message, "face 2")) << message;
    }
}

TEST(ObjReader, IndexZeroIsRejectedWithItsLine) {
    const std::string message = parseError(std::string(kSquareVertices) + "\nf 1 0 3\n");
    // 4 vertex lines and a blank line before it: line 6.
    EXPECT_TRUE(contains(message, "test.obj:6:")) << message;
    EXPECT_TRUE(contains(message, "index 0")) << message;
}

TEST(ObjReader, IndexBeyondTheLastVertexIsRejectedWithTheFaceLine) {
    const std::string message =
        parseError(std::string("f 1 2 3\n") + kSquareVertices + "f 1 3 5\nf 1 2 4\n");
    // Line 6 names vertex 5 of the file's 4; the forward reference on line 1 is within range.
    EXPECT_TRUE(contains(message, "test.obj:6:")) << message;
    EXPECT_TRUE(contains(message, "out of range")) << message;
    EXPECT_TRUE(contains(message, "5")) << message;
}

TEST(ObjReader, HugeIndexIsRejectedNotWrapped) {
    // 4294967297 would wrap to 1 in 32 bits.
    const std::string message = parseError(std::string(kSquareVertices) + "f 1 2 4294967297\n");
    EXPECT_TRUE(contains(message, "test.obj:5:")) << message;
}

TEST(ObjReader, RelativeIndexBeforeTheFirstVertexIsRejectedWithItsLine) {
    const std::string message = parseError("v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n");
    // On line 3 only 2 vertices are read: -3 points before the first.
    EXPECT_TRUE(contains(message, "test.obj:3:")) << message;
    EXPECT_TRUE(contains(message, "points before")) << message;
    EXPECT_TRUE(contains(message, "-3")) << message;
}

TEST(ObjReader, NonFiniteCoordinatesAreRejectedWithTheirLine) {
    const char* bad[] = {"v nan 0 0\n",  "v 0 NaN 0\n",   "v 0 0 inf\n",
                         "v -inf 0 0\n", "v 0 infinity 0\n", "v 0 0 -nan\n"};
    for (const char* line : bad) {
        SCOPED_TRACE(line);
        const std::string message = parseError(std::string("v 0 0 0\n") + line + "v 0 1 0\nf 1 2 3\n");
        EXPECT_TRUE(contains(message, "test.obj:2:")) << message;
        EXPECT_TRUE(contains(message, "not finite")) << message;
    }
}

TEST(ObjReader, LineNumbersCountCrlfLines) {
    const std::string message = parseError("v 0 0 0\r\n\r\nv 1 x 0\r\n");
    EXPECT_TRUE(contains(message, "test.obj:3:")) << message;
}

TEST(ObjReader, ErrorIsOneLine) {
    for (const char* text : {"v 1 x 3\n", "v 0 0 0\nf 1 0 2\n", "v 0 0 0\nf 1 2 3\n",
                             "v nan 0 0\n", "v 0 0 0\nf -2 1 1\n"}) {
        const std::string message = parseError(text);
        EXPECT_FALSE(contains(message, "\n")) << message;
    }
}

TEST(ObjReader, UnknownStatementsWarnOncePerKeywordWithTheFirstLine) {
    std::vector<std::string> warnings;
    const Mesh mesh = parse(
        "v 0 0 0\n"
        "foo 1\n"
        "v 1 0 0\n"
        "foo 2\n"
        "bar\n"
        "v 1 1 0\n"
        "cstype rat bspline\n"
        "bar x\n"
        "v 0 1 0\n"
        "foo\n"
        "f 1 2 3\nf 1 3 4\n",
        &warnings);
    expectSquare(mesh);
    ASSERT_EQ(warnings.size(), 3u);
    EXPECT_TRUE(contains(warnings[0], "test.obj:2:") && contains(warnings[0], "'foo'")) << warnings[0];
    EXPECT_TRUE(contains(warnings[1], "test.obj:5:") && contains(warnings[1], "'bar'")) << warnings[1];
    EXPECT_TRUE(contains(warnings[2], "test.obj:7:") && contains(warnings[2], "'cstype'")) << warnings[2];
}

TEST(ObjReader, UnknownStatementsAreSkippedWhenNoWarningListIsGiven) {
    expectSquare(parse(std::string("foo 1 2\n") + kSquareVertices + "bar\nf 1 2 3\nf 1 3 4\n"));
}

TEST(ObjReader, ReadObjNamesTheMissingFile) {
    TempDir dir;
    const std::string path = (dir.path() / "missing.obj").string();
    const std::string message = inputErrorOf([&] { readObj(path); });
    EXPECT_TRUE(contains(message, path)) << message;
    EXPECT_TRUE(contains(message, "cannot open")) << message;
}

TEST(ObjReader, ReadObjRejectsADirectory) {
    TempDir dir;
    const std::string message = inputErrorOf([&] { readObj(dir.path().string()); });
    EXPECT_TRUE(contains(message, dir.path().string())) << message;
}

TEST(ObjReader, ReadObjRecordsThePathForErrors) {
    TempDir dir;
    const fs::path file = dir.path() / "shape.obj";
    writeText(file, std::string(kSquareVertices) + "f 1 2 3\nf 1 3 4\n");
    const Mesh mesh = readObj(file.string());
    expectSquare(mesh);
    EXPECT_EQ(mesh.source.path, file.string());
    // 0-based face 1 is the second `f`, line 4 + 2; 0-based vertex 2 is the third `v`, line 3.
    EXPECT_EQ(describeFace(mesh.source, 1), file.string() + ":6: face 2");
    EXPECT_EQ(describeVertex(mesh.source, 2), file.string() + ":3: vertex 3");
}

// ---------------------------------------------------------------------------------------
// Truncated input: every prefix of a valid file is an InputError or a well-formed mesh

// Parses text[0, length) from a buffer of exactly that size (no terminator to lean on).
void expectPrefixParsesSafely(const std::string& text, std::size_t length) {
    std::unique_ptr<char[]> buffer(new char[length == 0 ? 1 : length]);
    std::copy(text.begin(), text.begin() + std::ptrdiff_t(length), buffer.get());
    Mesh mesh;
    try {
        mesh = parseObj(std::string_view(buffer.get(), length), "prefix.obj");
    } catch (const InputError& error) {
        EXPECT_TRUE(contains(error.what(), "prefix.obj")) << error.what();
        return;
    }
    const Index vertexCount = mesh.faces.vertexCount;
    ASSERT_EQ(mesh.positions.size(), std::size_t(vertexCount) * 3) << "prefix " << length;
    ASSERT_EQ(mesh.source.vertexLine.size(), vertexCount) << "prefix " << length;
    ASSERT_EQ(mesh.source.faceLine.size(), mesh.faces.faceCount()) << "prefix " << length;
    for (Index v : mesh.faces.verts) ASSERT_LT(v, vertexCount) << "prefix " << length;
    try {
        checkMesh(mesh);  // a well-formed prefix is valid or rejected, never a crash
    } catch (const InputError&) {
    }
}

// Every index form, CRLF, continuation of a vertex and a face, ignored statements.
constexpr const char* kEveryFeature =
    "# every feature\r\n"
    "mtllib m.mtl\r\n"
    "v 0 0 0\r\n"
    "v 1.5e0 0 0 1\r\n"
    "v 1 \\\r\n"
    "  1 0\r\n"
    "vt 0 0\r\n"
    "vn 0 0 1\r\n"
    "v\t0 1 0 0.5 0.5 0.5\r\n"
    "g part\r\n"
    "f 1 2/1 3/1/1\r\n"
    "f 1//1 \\\r\n"
    "  -2 -1\r\n"
    "v -1 0.5 0\r\n"
    "f 5/1 1/1/1 4//1\r\n";

TEST(ObjTruncation, HandWrittenFileIsValidWhole) {
    const Mesh mesh = parse(kEveryFeature);
    EXPECT_EQ(facesOf(mesh.faces), (std::vector<std::vector<Index>>{{0, 1, 2}, {0, 2, 3}, {4, 0, 3}}));
    EXPECT_NO_THROW(checkMesh(mesh));
}

TEST(ObjTruncation, EveryPrefixOfAHandWrittenFileIsAnErrorOrAWellFormedMesh) {
    const std::string text = kEveryFeature;
    for (std::size_t length = 0; length <= text.size(); ++length) {
        expectPrefixParsesSafely(text, length);
        if (HasFatalFailure()) return;
    }
}

TEST(ObjTruncation, PrefixesOfSpotAreErrorsOrWellFormedMeshes) {
    const std::string text = readText(PSUB_DATA "/spot_control_mesh.obj");
    // The file is 8822 bytes (wc -c): the bound checks the real mesh was read, not a stub.
    ASSERT_GT(text.size(), 8000u);
    // Every 5th prefix, and every prefix of the last 200 bytes (mid-face truncations).
    for (std::size_t length = 0; length <= text.size(); ++length) {
        if (length % 5 != 0 && length + 200 < text.size()) continue;
        expectPrefixParsesSafely(text, length);
        if (HasFatalFailure()) return;
    }
}

// ---------------------------------------------------------------------------------------
// Writing

TEST(ObjWriter, WritesOneBasedIndicesAndHeaderComments) {
    Faces faces;
    faces.vertexCount = 4;
    faces.addFace(std::vector<Index>{0, 1, 2});
    faces.addFace(std::vector<Index>{0, 2, 3});
    const std::string text = formatObj(faces, kSquarePositions, "first line\nsecond line");
    EXPECT_EQ(text,
              "# first line\n# second line\n"
              "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
              "f 1 2 3\nf 1 3 4\n");
}

TEST(ObjWriter, RoundTripOfSpotKeepsPositionsAndFaces) {
    const Mesh original = readObj(PSUB_DATA "/spot_control_mesh.obj");
    const Mesh again = parse(formatObj(original.faces, original.positions, "spot again"));
    ASSERT_EQ(again.faces.vertexCount, original.faces.vertexCount);
    EXPECT_EQ(again.faces.offsets, original.faces.offsets);
    EXPECT_EQ(again.faces.verts, original.faces.verts);
    ASSERT_EQ(again.positions.size(), original.positions.size());
    // Bound 1e-9 relative (9 significant digits, as in RoundTripKeepsArbitraryDoublesWithin1e9Relative):
    // a loose bound, not a measured error. formatObj writes std::to_chars' shortest round-trip
    // form (topology/obj.cpp), so the read-back is expected to be exact.
    for (std::size_t i = 0; i < original.positions.size(); ++i)
        EXPECT_LE(std::abs(again.positions[i] - original.positions[i]),
                  1e-9 * std::abs(original.positions[i])) << "coordinate " << i;
}

TEST(ObjWriter, RoundTripKeepsArbitraryDoublesWithin1e9Relative) {
    // Values that need more than 9 significant digits; and one unused vertex, which is kept.
    const std::vector<double> positions = {
        1.0 / 3.0,    -2.0 / 7.0 * 1e-5, 3.14159265358979e5,
        1.0000000049, 123456789.123,     -1e-300,
        6.02214076e23, 0.0,              -0.0,
        2.5,          -1.7976931348623157e308, 2.2250738585072014e-308,
        0.1 + 0.2,    1e100 / 3.0,       -8.123456789012345};
    Faces faces;
    faces.vertexCount = 5;
    faces.addFace(std::vector<Index>{0, 1, 2, 3});
    const Mesh again = parse(formatObj(faces, positions));
    ASSERT_EQ(again.faces.vertexCount, 5u);
    EXPECT_EQ(facesOf(again.faces), facesOf(faces));
    ASSERT_EQ(again.positions.size(), positions.size());
    for (std::size_t i = 0; i < positions.size(); ++i)
        EXPECT_LE(std::abs(again.positions[i] - positions[i]), 1e-9 * std::abs(positions[i]))
            << "coordinate " << i << ": wrote " << positions[i] << ", read back "
            << again.positions[i];
}

TEST(ObjWriter, RoundTripKeepsPolygonFacesOfEverySize) {
    Faces faces;
    faces.vertexCount = 9;
    faces.addFace(std::vector<Index>{0, 1, 2});
    faces.addFace(std::vector<Index>{2, 1, 3, 4});
    faces.addFace(std::vector<Index>{4, 3, 5, 6, 7, 8});
    std::vector<double> positions(27);
    for (std::size_t i = 0; i < positions.size(); ++i) positions[i] = double(i) * 0.25 - 3;
    const Mesh again = parse(formatObj(faces, positions));
    EXPECT_EQ(again.faces.vertexCount, 9u);
    EXPECT_EQ(facesOf(again.faces), facesOf(faces));
    EXPECT_EQ(again.positions, positions);
}

TEST(ObjReader, SkipsUtf8ByteOrderMark) {
    const Mesh mesh = parse("\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n");
    EXPECT_EQ(mesh.faces.vertexCount, 3u);
    EXPECT_EQ(facesOf(mesh.faces), (std::vector<std::vector<Index>>{{0, 1, 2}}));
}

TEST(ObjReader, AcceptsCommentsAfterStatements) {
    const Mesh mesh = parse("v 0 0 0 # a\nv 1 0 0\nv 0 1 0\nf 1 2 3 # the face\n");
    EXPECT_EQ(facesOf(mesh.faces), (std::vector<std::vector<Index>>{{0, 1, 2}}));
}

TEST(ObjReader, AcceptsLoneCarriageReturnLineEnds) {
    const Mesh mesh = parse("v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r");
    EXPECT_EQ(mesh.faces.vertexCount, 3u);
    EXPECT_EQ(mesh.source.faceLine, (std::vector<std::uint32_t>{4}));
}

TEST(ObjReader, CountsLinesOverLoneCarriageReturns) {
    const std::string message = parseError("v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 x\r");
    EXPECT_TRUE(contains(message, "test.obj:4:")) << message;
}

TEST(ObjReader, RejectsDoubleSign) {
    const std::string message = parseError("v +-1 0 0\n");
    EXPECT_TRUE(contains(message, "test.obj:1:")) << message;
}

TEST(ObjReader, ShowsControlBytesInMessagesAsQuestionMarks) {
    const std::string message = parseError("v 0 \x1b[31m 0\n");
    EXPECT_FALSE(contains(message, "\x1b")) << message;
    EXPECT_TRUE(contains(message, "?[31m")) << message;
}

}  // namespace
}  // namespace psub
