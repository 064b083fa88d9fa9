// psub/topology.h: meshes and their connectivity. OBJ reading and writing, validation,
// half-edge connectivity, vertex classification, closed-form counts, the paired-method
// preprocessing and the topological P-S step, level after level. This layer never computes
// a refined position; the rules live in psub/rules.h.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace psub {

using Index = std::uint32_t;
inline constexpr Index kNoIndex = ~Index(0);

// Untrusted input was rejected. what() is one line naming the file, line and element.
class InputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Polygon faces over vertices 0..vertexCount-1 in compressed rows: face f is
// verts[offsets[f] .. offsets[f+1]), counter-clockwise. A face corner is also the half-edge
// that leaves it: corner h runs from verts[h] to verts[next(h)].
struct Faces {
    Index vertexCount = 0;
    std::vector<Index> offsets{0};  // faceCount()+1 entries, offsets[0] == 0
    std::vector<Index> verts;

    Index faceCount() const { return Index(offsets.size() - 1); }
    Index faceSize(Index f) const { return offsets[f + 1] - offsets[f]; }
    std::span<const Index> face(Index f) const {
        return {verts.data() + offsets[f], faceSize(f)};
    }
    void addFace(std::span<const Index> corners) {
        verts.insert(verts.end(), corners.begin(), corners.end());
        offsets.push_back(Index(verts.size()));
    }
};

// Where a mesh came from, so that errors can name the file and line. Empty lines vectors
// mean "built in memory": errors then name elements only.
struct Source {
    std::string path;
    std::vector<std::uint32_t> vertexLine;  // 1-based line of each `v`
    std::vector<std::uint32_t> faceLine;    // 1-based line of each `f`
};

// A face-varying channel (texture coordinates first): every face corner (each entry of
// Faces::verts, in the same order) names one of `values` (`width` doubles each). Two faces
// that meet at a vertex but name different values there are on two sides of a seam
// (docs/face-varying.md). Empty `corners`: the mesh has no such channel.
struct FaceVarying {
    std::uint32_t width = 2;
    std::vector<double> values;
    std::vector<Index> corners;            // one per face corner, or none
    std::vector<std::uint32_t> valueLine;  // 1-based line of each value (`vt`), when read from OBJ

    bool empty() const { return corners.empty(); }
    Index valueCount() const { return width == 0 ? 0 : Index(values.size() / width); }
};

// A polygon mesh: faces plus xyz positions (3 doubles per vertex), and optional UVs.
struct Mesh {
    Faces faces;
    std::vector<double> positions;
    Source source;
    FaceVarying uv;
};

// "FILE:LINE: face N" / "face N": messages number faces and vertices from 1, as OBJ does.
std::string describeFace(const Source& source, Index f);
std::string describeVertex(const Source& source, Index v);

// ---------------------------------------------------------------------------------------
// Numeric range

// Every P-S rule is an affine combination of control points whose weights sum to 1 and are
// non-negative, except the paper's valence-2 vertex rule (centre -1/2; |weights| sum to 2), so
// refined positions stay within a small multiple of the largest input |coordinate|. Commands
// refuse input beyond a limit per evaluation precision, chosen so that the refined positions
// and what is derived from them still fit: float (Vulkan, play, render, the demo's timings)
// 1e8, because normals take fourth powers of coordinates (Newell sums, then their length);
// double (subdivide on the CPU, stats, compare) 1e60, because compare's point-to-triangle
// distances multiply dot products (fourth powers).
// The library itself refuses nothing: out-of-range or non-finite control points passed to an
// evaluator give non-finite refined values and normals, never a crash or an out-of-bounds access.
enum class Precision { Float, Double };
double coordinateLimit(Precision precision);
const char* precisionName(Precision precision);

// Throws InputError "FILE:LINE: vertex N: coordinate y = 1e+39 is outside +-1e+08, ..." for
// the first coordinate whose magnitude exceeds coordinateLimit(precision) (or is NaN).
void checkCoordinateRange(const Mesh& mesh, Precision precision);

// Output boundary: throws InputError "INPUT: WHAT vertex N is not finite ..." for the first
// non-finite value of `xyz` (3 per vertex), so that no command writes one.
void requireFinite(std::span<const double> xyz, const std::string& input, const std::string& what);
void requireFinite(std::span<const float> xyz, const std::string& input, const std::string& what);
// Whether every value is finite (requireFinite's test, without the error).
bool allFinite(std::span<const float> values);

// ---------------------------------------------------------------------------------------
// OBJ I/O

// Reads `v`, `vt` (u v [w]; w ignored) and `f` statements (face entries i, i/t, i/t/n, i//n,
// negative indices) into positions, faces and Mesh::uv; ignores vn vp g o s usemtl mtllib l
// and comments, accepts CRLF and `\` continuation
// lines. Throws InputError naming file and line for unreadable files, malformed numbers,
// non-finite coordinates or texture coordinates and indices (v or vt) that are zero or out of
// range. A file where some face lacks a `vt` at some corner while others name one loses the
// channel, with a warning naming the first such face; so does one with no `vt` statement. Unknown statements are reported once each in `warnings` (if given)
// and skipped.
Mesh readObj(const std::string& path, std::vector<std::string>* warnings = nullptr);

// The whole of input file `path`. Only a regular file is read: a FIFO (opened without
// blocking, so it cannot hang), a directory or a device throws InputError naming the path and
// what it is, as does a file that cannot be opened, read or held in memory.
std::string readInputFile(const std::string& path);
Mesh parseObj(std::string_view text, const std::string& name,
              std::vector<std::string>* warnings = nullptr);

// Serialises a mesh as OBJ text: `header` lines as comments, then `v` and `f` lines.
std::string formatObj(const Faces& faces, std::span<const double> positions,
                      std::string_view header = {});

// The same with a face-varying channel: `v` lines, `vt` lines (the first two numbers of each
// `width`-wide value), then faces `f v/vt` whose corners name position vertex faceVerts[i]
// and value faceValues[i], faces in compressed rows faceOffsets.
std::string formatObjWithUv(std::span<const double> positions, std::span<const double> values,
                            std::uint32_t width, std::span<const std::uint32_t> faceOffsets,
                            std::span<const std::uint32_t> faceVerts,
                            std::span<const std::uint32_t> faceValues, std::string_view header = {});

// ---------------------------------------------------------------------------------------
// Connectivity

enum class VertexKind : std::uint8_t {
    Interior,     // manifold, one closed fan of faces
    Boundary,     // manifold, one open fan (on at least one boundary edge)
    NonManifold,  // two or more fans meet here (bow-tie / pinch): retained like boundary
    Unused,       // no face uses it: kept and carried unchanged
};

// Half-edge connectivity built in linear time from Faces (counting sorts, no per-edge
// allocation). Half-edge h is face corner h of Faces::verts.
struct Connectivity {
    std::vector<Index> faceOf;        // per half-edge: the face holding it
    std::vector<Index> next;          // per half-edge: next corner of the same face
    std::vector<Index> twin;          // per half-edge: opposite half-edge, kNoIndex on boundary
    std::vector<Index> edgeOf;        // per half-edge: its undirected edge
    std::vector<Index> edgeHalfedge;  // per edge: the first half-edge met in face order
    std::vector<Index> outOffsets;    // per vertex: CSR rows into outgoing
    std::vector<Index> outgoing;      // half-edges leaving each vertex, in face order
    std::vector<Index> valence;       // per vertex: number of incident edges
    std::vector<VertexKind> kind;     // per vertex
    Index boundaryEdgeCount = 0;

    Index edgeCount() const { return Index(edgeHalfedge.size()); }
    std::span<const Index> outgoingOf(Index v) const {
        return {outgoing.data() + outOffsets[v], outOffsets[v + 1] - outOffsets[v]};
    }
};

// Builds connectivity. Throws InputError (naming the face, the edge and, through `source`,
// the line) on an edge used by more than two faces or by two faces in the same direction.
// Faces must already be well formed (see validateFaces).
Connectivity buildConnectivity(const Faces& faces, const Source& source = {});

// ---------------------------------------------------------------------------------------
// Validation (docs/scheme.md, "Bad input")

struct CheckedMesh {
    Connectivity connectivity;
    std::vector<std::string> warnings;  // unused and non-manifold vertices
};

// Checks faces (at least one, at least 3 corners, no repeated vertex, indices in range) and
// positions (finite, 3 per vertex), builds connectivity (manifold edges, consistent
// orientation). Throws InputError naming the first defect; returns warnings for what docs/scheme.md
// accepts (unused vertices, non-manifold vertices).
CheckedMesh checkMesh(const Mesh& mesh);
void validateFaces(const Faces& faces, const Source& source = {});

// ---------------------------------------------------------------------------------------
// P-S topology

enum class Preprocess { Auto, Always, Never };

// First face that keeps a mesh from being legal P-S input (faces are quads, or triangles
// with at least one boundary edge), or kNoIndex when it is legal.
Index firstNonPSFace(const Faces& faces, const Connectivity& connectivity);

// Resolves Preprocess::Auto; throws InputError for Never on a mesh that is not P-S input.
bool needsPreprocessing(const Faces& faces, const Connectivity& connectivity, Preprocess mode,
                        const Source& source = {});

// How the boundary is refined (docs/scheme.md, "Decisions").
// Paper (the default): boundary vertices and edges are kept, never refined.
// Smooth (beyond the paper, never the default): the first P-S step of every pair (P-S steps
// 1, 3, 5, ...; the paired method is not counted) also splits each boundary edge at a new
// vertex, with the cubic B-spline curve rules (stencils/), so that after 2k steps the boundary
// polyline is Catmull-Clark's after k steps. The interior keeps the paper's rules.
enum class Boundary { Paper, Smooth };

// "paper" or "smooth".
const char* boundaryName(Boundary boundary);

// True when P-S step `psStep` (1-based, the paired method not counted) splits boundary edges.
inline bool splitsBoundary(Boundary boundary, int psStep) {
    return boundary == Boundary::Smooth && psStep >= 1 && psStep % 2 == 1;
}

// The boundary neighbours of a vertex of kind Boundary (one open fan): `previous` ends the
// boundary edge coming into v, `next` ends the boundary edge leaving v.
struct BoundaryNeighbours {
    Index previous, next;
};
BoundaryNeighbours boundaryNeighbours(const Faces& faces, const Connectivity& connectivity, Index v);

// One topological step, shared by the paired method and P-S: vertex v keeps index v, face f
// gets vertex vertexCount+f; the edges met first in face order, each from the half-edge a->b
// of face f, become [a, F(g), b, F(f)] (interior, g holds b->a) or [a, b, F(f)] (boundary).
// With `splitBoundary`, the i-th boundary edge (in edge order) also gets vertex
// vertexCount + faceCount + i, M, and becomes the two triangles [a, M, F(f)], [M, b, F(f)].
Faces refineFaces(const Faces& faces, const Connectivity& connectivity, bool splitBoundary = false);

struct Level {
    Faces faces;
    Connectivity connectivity;
};

// One refined level built directly from its parent: the same faces as refineFaces and the
// same connectivity as buildConnectivity on them, without searching for twins.
Level refineLevel(const Level& parent, bool splitBoundary = false);
// The same child from a parent that is not needed afterwards: the parent is left empty, and
// freed while the child is built, so that the step's peak holds the child and only part of
// the parent (the largest refinements are bound by this peak).
Level refineLevel(Level&& parent, bool splitBoundary = false);

// The levels of a refinement: levels[0] is the input; when `preprocessed`, levels[1] is the
// paired-method quad mesh; every further level is one P-S step.
struct Hierarchy {
    std::vector<Level> levels;
    bool preprocessed = false;
    Boundary boundary = Boundary::Paper;

    int psSteps() const { return int(levels.size()) - 1 - (preprocessed ? 1 : 0); }
    // True when levels[k] was built from levels[k-1] with its boundary edges split.
    bool splitsBoundary(std::size_t k) const {
        return psub::splitsBoundary(boundary, int(k) - (preprocessed ? 1 : 0));
    }
    const Level& finest() const { return levels.back(); }
};

// Refines `steps` P-S steps after optional preprocessing. `onLevel(levelIndex, seconds)` is
// called after each level is built (progress and timing), when given.
Hierarchy refineTopology(Faces input, Connectivity connectivity, bool preprocess, int steps,
                         const std::function<void(int level, double seconds)>& onLevel = {},
                         Boundary boundary = Boundary::Paper);

// ---------------------------------------------------------------------------------------
// Face-varying topology (docs/face-varying.md)

// Checks a mesh's face-varying channel: width 1..4, one index per face corner, every index in
// range, finite values, and no value named at two different vertices. Throws InputError
// naming the file, line and face (or value); does nothing when the channel is empty.
void checkFaceVarying(const Mesh& mesh);

// Gives each value that faces name at two or more different vertices (an OBJ `vt` reused
// across vertices, a glTF vertex whose copies were kept apart) one copy per further vertex,
// appended after the values (same numbers, same line), so that every value belongs to one
// vertex. Indices out of range are left for checkFaceVarying to report.
void separateSharedValues(Mesh& mesh);

// One level of a face-varying channel: the level's faces over face-varying vertices (a face
// that straddles a seam of the parent level split into two triangles, f's side first), their
// connectivity, and per position half-edge h of the level (Faces::verts order) the
// face-varying face holding it and the values at its two ends.
struct FaceVaryingLevel {
    Faces faces;                       // over face-varying vertices
    Connectivity connectivity;         // of `faces`; seams are its boundary edges
    std::vector<Index> positionOf;     // per face-varying corner: the position vertex
    std::vector<std::uint8_t> split;   // per face-varying face: 1 for a triangle of a split face
    std::vector<Index> faceOf;         // per position half-edge: its face-varying face
    std::vector<Index> valueFrom, valueTo;  // per position half-edge: values at its ends

    // True when position half-edge h (twin t) crosses a seam: the faces name different values.
    bool seam(Index h, Index t) const {
        return t != kNoIndex && (valueFrom[h] != valueTo[t] || valueTo[h] != valueFrom[t]);
    }
};

// Level 0: the mesh's own faces over its values (checkFaceVarying must have passed).
FaceVaryingLevel faceVaryingBase(const Mesh& mesh, const Connectivity& connectivity);

// The child of `parent` for the position step from `positions` (refineLevel without a split
// boundary): the child faces of refineFaces' order, corners mapped, seams split.
FaceVaryingLevel refineFaceVarying(const FaceVaryingLevel& parent, const Level& positions);

// ---------------------------------------------------------------------------------------
// Counts and classification

struct Counts {
    std::uint64_t vertices = 0, edges = 0, faces = 0;
    std::uint64_t triangles = 0, quads = 0, boundaryEdges = 0;
};

// Counts read off a mesh.
Counts countMesh(const Faces& faces, const Connectivity& connectivity);

// Counts after one topological step: V' = V + F, E' = 2E, F' = E, boundary edges and
// triangles' = Eb, quads' = E - Eb; a step that splits the boundary adds Eb to V', E', F'
// and doubles boundary edges and triangles.
Counts countsAfterStep(const Counts& c, bool splitBoundary);

// Counts after `steps` topological steps (the paired method, when `preprocessed`, then P-S
// steps) of a mesh with counts `c`; closed form for Boundary::Paper: V + F + (2^(k-1) - 1) E,
// 2^k E, 2^(k-1) E. Caller keeps steps < 40.
Counts countsAfterSteps(const Counts& c, int steps, Boundary boundary = Boundary::Paper,
                        bool preprocessed = false);

struct VertexClasses {
    std::uint64_t regular = 0, extraordinary = 0, boundary = 0, nonManifold = 0, unused = 0;
};

// Regular: interior of valence 4 or boundary of valence 2 or 3. Extraordinary: every other
// used vertex (non-manifold vertices included). Unused vertices are neither.
VertexClasses classifyVertices(const Connectivity& connectivity);

}  // namespace psub
