// psub/animation.h: the per-frame control points of an animated mesh, for real-time playback.
// Two sources: procedural deformers (wave, twist, bend) and glTF 2.0 files (skin, node
// hierarchy, morph targets, clips) posed on the CPU. The caller refines the result every frame
// with stencil tables (psub/evaluator.h); nothing here refines. Positions are packed xyz
// floats. Per-frame calls allocate nothing and throw nothing; bad files throw InputError.
#pragma once

#include "psub/topology.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace psub {

// ---------------------------------------------------------------------------------------
// Procedural deformers
//
// Notation, from the rest positions' axis-aligned box: min m, max M, centre c = (m + M) / 2,
// extents e = M - m, size L = max(e) (1 when every extent is 0). Axes are ranked with ties
// broken in the order y, x, z. a = the longest axis; u ("up") = the shortest axis; d = the
// longest axis other than u; b = the longer of the two axes other than a; (a, a+1, a+2) mod 3
// is right-handed. phase(t) = 2 pi t / kProceduralPeriod. Every deformer has period
// kProceduralPeriod in t; twist and bend are the identity at t = 0.
//
//   Wave:  p'_u = p_u + kWaveAmplitude L sin(2 pi (p_d - m_d) / (L / 2) - phase(t)): two
//          wavelengths across the box, travelling towards +d, one wavelength per period.
//   Twist: rotation about the line through c along a, by the angle
//          theta = kTwistAngle sin(phase(t)) (p_a - c_a) / L, which grows linearly along a
//          (the two ends turn by +-kTwistAngle / 2 at the peak): with q = p - c,
//          p'_{a+1} = c_{a+1} + cos(theta) q_{a+1} - sin(theta) q_{a+2},
//          p'_{a+2} = c_{a+2} + sin(theta) q_{a+1} + cos(theta) q_{a+2}.
//   Bend:  the axis a is bent into a circular arc in the (a, b) plane, with curvature
//          k = kBendAngle sin(phase(t)) / L (the whole length turns by kBendAngle at the peak):
//          with s = p_a - c_a, h = p_b - c_b, phi = k s,
//          p'_a = c_a + sin(phi) / k - h sin(phi),
//          p'_b = c_b + (1 - cos(phi)) / k + h cos(phi)   (p' = p when k = 0).

enum class Procedural { Wave, Twist, Bend };

inline constexpr double kProceduralPeriod = 2.0;  // seconds
inline constexpr double kWaveAmplitude = 0.05;    // fraction of the box size L
inline constexpr double kTwistAngle = std::numbers::pi / 2;
inline constexpr double kBendAngle = std::numbers::pi / 2;

// The deformer named `name` ("wave", "twist" or "bend", lower case), or nullopt.
std::optional<Procedural> parseProcedural(std::string_view name);

// The lower-case name of `kind`, as parseProcedural reads it.
std::string_view proceduralName(Procedural kind);

// The axis-aligned box of some positions, computed once from the rest positions.
struct RestBounds {
    std::array<double, 3> min{0, 0, 0};
    std::array<double, 3> max{0, 0, 0};
};

// The box of packed xyz positions (all zeros when there are none). positions.size() % 3 == 0.
RestBounds restBounds(std::span<const float> positions);

// Writes the rest positions deformed by `kind` at time `seconds` into `out`; allocates nothing.
// rest.size() % 3 == 0; out.size() == rest.size(); out must not overlap rest; seconds finite.
void deformProcedural(Procedural kind, const RestBounds& bounds, std::span<const float> rest,
                      double seconds, std::span<float> out);

// ---------------------------------------------------------------------------------------
// glTF 2.0 (.gltf with embedded or external buffers, or .glb)

// A node's local transform as translation, rotation (unit quaternion x, y, z, w) and scale.
struct NodeTransform {
    std::array<double, 3> translation{0, 0, 0};
    std::array<double, 4> rotation{0, 0, 0, 1};
    std::array<double, 3> scale{1, 1, 1};
};

// One node of the hierarchy. A node given by a matrix keeps it (column-major, as glTF); glTF
// forbids animating such a node, and readGltf rejects clips that try.
struct GltfNode {
    std::string name;
    std::int32_t parent = -1;  // -1 for a root
    NodeTransform rest;        // identity when `matrix` is set
    std::optional<std::array<double, 16>> matrix;
};

// Linear blend skinning data: up to 4 influences per cage vertex.
struct GltfSkin {
    std::vector<std::uint32_t> jointNodes;                   // node of each joint
    std::vector<std::array<double, 16>> inverseBindMatrices;  // per joint, column-major
    std::vector<std::uint16_t> joints;  // 4 per cage vertex: indices into jointNodes
    std::vector<float> weights;         // 4 per cage vertex, >= 0, summing to 1
    // A slot of weight 0 reads joint 0, whatever the file says (so such slots never block welding).
};

// Morph targets: POSITION deltas only (NORMAL and TANGENT targets are ignored).
struct GltfMorphs {
    std::uint32_t targetCount = 0;
    std::vector<float> deltas;          // targetCount * 3 * cage vertex count, target-major
    std::vector<float> defaultWeights;  // targetCount: the node's weights, else the mesh's, else 0
};

enum class GltfPath : std::uint8_t { Translation, Rotation, Scale, Weights };
enum class GltfInterpolation : std::uint8_t { Step, Linear, CubicSpline };

// One animated property. Per keyframe `width` values (3 for translation and scale, 4 for a
// rotation quaternion x, y, z, w, the morph target count for weights); CUBICSPLINE keys hold
// in-tangent, value and out-tangent, in that order (3 * width values).
struct GltfChannel {
    std::uint32_t node = 0;
    GltfPath path = GltfPath::Translation;
    GltfInterpolation interpolation = GltfInterpolation::Linear;
    std::uint32_t width = 3;
    std::vector<float> times;   // seconds, non-decreasing, finite
    std::vector<float> values;  // times.size() * width (* 3 for CUBICSPLINE)
};

// An animation clip; it plays over [0, duration] seconds.
struct GltfClip {
    std::string name;
    double duration = 0;  // the last keyframe time of any channel
    std::vector<GltfChannel> channels;
};

// An image as stored in the file (never decoded here): PNG or JPEG bytes, checked by their
// magic bytes, from a buffer view, a data URI or an external file.
struct GltfImage {
    std::string mimeType;             // "image/png" or "image/jpeg"
    std::vector<unsigned char> bytes;
    std::string name;                 // the image's name, else its file name; may be empty
    std::size_t index = 0;            // its index in the file's images
};

// glTF sampler codes (e.g. 10497 REPEAT, 33071 CLAMP_TO_EDGE, 9729 LINEAR); -1: not given.
struct GltfSampler {
    int magFilter = -1, minFilter = -1;
    int wrapS = 10497, wrapT = 10497;
};

// What the cage's material says about its base colour (pbrMetallicRoughness): colour =
// factor * texture(TEXCOORD_0), in linear RGBA; the texture is sRGB-encoded as glTF says.
struct GltfMaterial {
    std::string name;
    std::array<double, 4> baseColorFactor{1, 1, 1, 1};
    std::optional<GltfImage> baseColorTexture;
    GltfSampler sampler;  // the texture's sampler (defaults without a texture)
};

// What readGltf loads. Vertices of the file ("glTF vertices") are numbered primitive after
// primitive; glTF splits a vertex wherever a face attribute changes (UV and normal seams), so
// glTF vertices whose POSITION, joints, weights and morph deltas are all bitwise equal are
// welded into one cage vertex.
// mesh.uv, when primitives carry TEXCOORD_0, keeps the seams: one UV value per glTF vertex,
// each triangle corner naming its glTF vertex's value. Welding by position can make touching
// shells (lips, eyelids) share an edge three or more ways, or twice in one direction; the
// vertices of such edges are then un-welded again, one copy per connected shell (and, where
// that is not enough, per face), so that the cage is manifold along edges.
struct GltfAsset {
    Mesh mesh;  // the cage: triangles over the welded vertices; source.path is the file
    std::optional<GltfMaterial> material;      // the first primitive's material, when it has one
    std::vector<Index> cageVertexOf;           // per glTF vertex: its cage vertex
    std::vector<Index> primitiveFirstVertex;   // per primitive: its first glTF vertex
    std::uint32_t meshNode = 0;                // the node that instantiates the mesh
    std::vector<GltfNode> nodes;               // every node of the file, in file order
    std::vector<std::uint32_t> nodeOrder;      // every node, each after its parent
    std::optional<GltfSkin> skin;              // when the mesh node has a skin
    GltfMorphs morphs;
    std::vector<GltfClip> clips;               // every animation of the file, in file order
    std::vector<std::string> warnings;         // ignored data, dropped degenerate triangles
};

// Loads the cage from `path` (.gltf or .glb, told apart by content): the mesh of the first
// node that has both a mesh and a skin, else of the first node with a mesh; its primitives
// (TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN, indexed or not) merged and welded; its skin
// (JOINTS_0 / WEIGHTS_0, weights normalised), morph targets, every node and every clip
// (LINEAR, STEP and CUBICSPLINE samplers), TEXCOORD_0 (float, or normalized unsigned byte or
// short) and the base colour of the material (primitives with other materials: a warning).
// Run checkMesh on `mesh` as for readObj.
// Throws InputError naming the file and the element, numbered from 0 as in the JSON
// ("FILE: accessor 3 (mesh 0 primitive 1 indices): ..."), for unreadable or invalid files, a
// file without a mesh node, points or lines, indices, nodes or samplers out of range, joints
// out of range in a slot of non-zero weight, accessors that overrun their buffer view,
// non-finite positions, weights, matrices or keyframes, negative or all-zero weights,
// decreasing keyframe times, a node hierarchy with a cycle, TEXCOORD_0 of the wrong type or
// count, a material, texture or image index out of range, a base colour texture image that
// is missing, empty, or neither PNG nor JPEG. Channels on nodes that move
// neither the skin nor the mesh are kept and simply change nothing.
GltfAsset readGltf(const std::string& path);

// The index of the first clip named `name`, or nullopt.
std::optional<std::size_t> findClip(const GltfAsset& asset, std::string_view name);

// ---------------------------------------------------------------------------------------
// glTF output

// A refined surface as psub writes it: faces over position vertices, with optional per-corner
// UVs (the faces of a FaceVaryingTable: faceVerts name position vertices, faceValues UV values).
struct GltfSurface {
    std::span<const double> positions;          // 3 per vertex, finite
    std::span<const double> normals;            // 3 per vertex, or empty: no NORMAL (zero ones: +z)
    std::span<const std::uint32_t> faceOffsets;  // faceCount + 1, from 0; faces of >= 3 corners
    std::span<const std::uint32_t> faceVerts;    // per corner: its vertex; counter-clockwise
    std::span<const std::uint32_t> faceValues;   // per corner: its UV value; empty: no UVs
    std::span<const double> uvValues;           // 2 per UV value
};

// The bytes of one glTF 2.0 asset holding `surface` as one triangle mesh (faces fan-
// triangulated from their first corner) on one node: a glTF vertex per distinct (position
// vertex, UV value) pair, with POSITION (bounded by min/max), NORMAL (normalised) and TEXCOORD_0 (float),
// 32-bit indices, and `material` (base colour factor and texture, when given; the image is
// stored in the buffer; without UVs the texture is left out, as glTF requires). binary: a .glb; otherwise a self-contained .gltf whose buffer is a
// base64 data URI. `generator` goes into asset.generator. Passes the Khronos glTF Validator
// with no error and no warning (tests/gltf_validator).
std::string formatGltf(const GltfSurface& surface, const GltfMaterial* material, bool binary,
                       const std::string& generator);

// Poses a GltfAsset in world space: morph targets first, then linear blend skinning with
// world(joint) * inverseBind(joint) (glTF ignores a skinned mesh's own node transform), or,
// for a mesh without a skin, the mesh node's world transform; in float. Every buffer is allocated by the
// constructor; pose() allocates nothing. Keeps a reference to the asset: it must outlive the
// player. Not thread-safe: one player per thread.
class GltfPlayer {
public:
    explicit GltfPlayer(const GltfAsset& asset);

    std::size_t vertexCount() const { return rest_.size() / 3; }
    std::size_t clipCount() const { return asset_.clips.size(); }

    // The cage positions as stored in the file (no morph, no transform). out.size() == 3 * vertexCount().
    void restPose(std::span<float> out) const;

    // The pose with no clip: rest node transforms and default morph weights.
    void staticPose(std::span<float> out);

    // The pose of clip `clip` at `seconds`, wrapped into [0, duration) when `loop`, else
    // clamped to [0, duration]. clip < clipCount(); seconds finite; out.size() == 3 * vertexCount().
    void pose(std::size_t clip, double seconds, std::span<float> out, bool loop = true);

    // Node `node`'s local transform in the last pose (its rest transform before any).
    // node < asset.nodes.size().
    const NodeTransform& localTransform(std::size_t node) const { return local_[node]; }

    // The morph target weights of the last pose (the defaults before any).
    std::span<const float> morphWeights() const { return weights_; }

private:
    void resetToRest();
    void applyClip(const GltfClip& clip, double time);
    void computeWorldMatrices();
    void deform(std::span<float> out);

    const GltfAsset& asset_;
    std::vector<float> rest_;                       // 3 per cage vertex
    std::vector<NodeTransform> local_;              // per node
    std::vector<std::array<double, 16>> world_;     // per node, column-major
    std::vector<std::array<float, 12>> skinning_;   // per joint: rows of the 3x4 affine part
    std::vector<float> weights_;                    // per morph target
    std::vector<double> sample_;                    // one keyframe value of the widest channel
};

}  // namespace psub
