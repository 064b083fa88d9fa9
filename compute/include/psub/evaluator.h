// psub/evaluator.h: applies stencil tables (psub/tables.h) to vertex buffers on the CPU: the
// CPU's own tools (any width, float or double, row ranges with a layout per buffer). The
// contract every backend follows is psub/evaluate.h. Results are gathered per row, so they
// never depend on threading. Reads tables only, never topology.
#pragma once

#include "psub/tables.h"
#include "psub/tiled.h"

#include <atomic>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace psub {

// Where a primvar sits in an interleaved buffer: element i occupies
// buffer[i * stride + offset .. + length). Any length: 3 and 4 have fast paths.
struct BufferLayout {
    std::uint32_t offset = 0, length = 3, stride = 3;

    bool valid() const { return length > 0 && offset + length <= stride; }
};

// A table's four-source rows (n = 3, m = 0: the face points of quads, the vertex points from
// face points), each source a 16-bit offset from a base per block of kNarrowBlock rows and per
// source position: 8 bytes of indices a row for a frame to read instead of 16, and no
// destination where a block's are consecutive (docs/design.md, "Narrow rows"). Group g's rows
// are blocks firstBlock[g] on (kNoNarrowRows: the group has none): row r's four offsets at
// offsets[4 (kNarrowBlock * firstBlock[g] + r) + j], its block b = firstBlock[g] + r / kNarrowBlock's
// four bases at bases[4 b], the first kWideBlock where a source lies more than 65,535 vertices
// past its position's least in the block (those rows read `indices`), and its first row's
// destination at firstDestination[b], where each row's is the one before's plus 1 (else
// kScattered: the rows read `destinations`).
constexpr std::uint32_t kNarrowBlock = 64, kNoNarrowRows = UINT32_MAX, kWideBlock = UINT32_MAX,
                        kScattered = UINT32_MAX;
struct NarrowRows {
    std::vector<std::uint32_t> firstBlock;        // per group of the table
    std::vector<std::uint16_t> offsets;           // 4 per row: its sources less their bases
    std::vector<std::uint32_t> bases;             // per block: a base per source position
    std::vector<std::uint32_t> firstDestination;  // per block
};
// The copy of the groups `copied` marks (copied[g] nonzero; empty: every four-source group).
NarrowRows narrowRows(const PerLevelTable& table, std::span<const std::uint8_t> copied = {});
// The table bytes a frame reads less with the copy: the indices of its fitting blocks (16 bytes
// a row against the copy's 8) and the destinations of its consecutive ones, less its bases and
// first destinations (20 bytes a block).
std::uint64_t narrowBytesSaved(const PerLevelTable& table, const NarrowRows& narrow);

// How evaluateLevelRows may read its buffers and indices (the defaults: every load checked,
// every index read whole).
struct RowReads {
    // Every vertex the rows read from the source (the destination) can be read 16 bytes at a
    // time: at least one more value can be read past its last vertex, or (the destination) no
    // readsOwnLevel row reads that vertex. The kernel then reads them so, untested.
    bool sourcePadded = false, destinationPadded = false;
    // The table's rows as narrowRows made them from it, read instead of `indices` where a row
    // fits (float, 3 values per vertex, packed buffers, readsNarrowRows), or null.
    const NarrowRows* narrow = nullptr;
};
// Whether evaluateLevelRows reads group `group`'s rows from `reads.narrow` (float, 3 values a
// vertex, packed buffers): four sources, a diagonal term of +0 (the kernel's lean rows), and the
// buffers they read padded (the destination for readsOwnLevel rows; for a
// VertexFromCentreAndFacePoints row the source too, its centre's). What narrowRows's
// `copied` should mark for a frame that reads so.
bool readsNarrowRows(const RowGroup& group, const RowReads& reads);

// The CPU evaluator's threads' shares of a frame's rows. Thread t of n takes the rows of each
// group (or of a level's work) from rowShareStart(count, bounds, t, n) to rowShareStart(count,
// bounds, t + 1, n): from the fraction bounds[t] of them (ascending, bounds[0] = 0, bounds[n] = 1),
// so that consecutive threads' shares meet exactly, whatever the fractions.
std::uint64_t rowShareStart(std::uint64_t count, const double* bounds, std::uint64_t t, std::uint64_t n);
// After a frame: moves each thread's fraction (bounds, n + 1 values) a quarter of the way toward
// its share of the team's speed in that frame (its fraction over seconds[secondsApart t], the
// seconds it spent on its rows), none under a fifth of an even share, so that a thread on a
// slower core (a virtual CPU whose sibling another guest loads, an efficiency core) gets fewer
// rows; then zeroes `seconds`. Leaves the fractions as they are where a thread spent no time.
void balanceRowShares(std::span<double> bounds, std::span<double> seconds, std::size_t secondsApart);

// The barrier between a frame's row phases (two a level), shared by the team of the OpenMP
// parallel region that waits at it: no thread leaves wait() before every thread of the team has
// entered it, and what each wrote before is visible to all after. libgomp's `omp barrier` makes
// a system call to wake sleepers each time, about 1.5 us on a 2-vCPU VM against 0.4 us for this
// one (bench/README.md, "Session 37"). It spins, then yields the core at each look (more
// threads than cores). Reusable: one object for every phase of a frame.
class TeamBarrier {
public:
    void wait();

private:
    alignas(64) std::atomic<std::uint32_t> arrived_{0};
    alignas(64) std::atomic<std::uint32_t> generation_{0};
};

// Rows [rowBegin, rowEnd) of per-level table `level` (numbered within the level, in table
// order): `source` holds the parent level's vertices, `destination` the child level's.
// readsOwnLevel rows (a level's last groups) read `destination` (but a
// VertexFromCentreAndFacePoints row's centre, from `source`): the level's rows before them must
// have been written (on one thread, the rows in table order do that).
template <class T>
void evaluateLevelRows(const PerLevelTable& table, std::size_t level, const T* source,
                       BufferLayout sourceLayout, T* destination, BufferLayout destinationLayout,
                       std::uint64_t rowBegin, std::uint64_t rowEnd, RowReads reads = {});

// Rows [rowBegin, rowEnd) of a factorized table: `source` holds the control points,
// `destination` the finest level's vertices.
template <class T>
void evaluateFactorizedRows(const FactorizedTable& table, const T* source,
                            BufferLayout sourceLayout, T* destination,
                            BufferLayout destinationLayout, std::uint32_t rowBegin,
                            std::uint32_t rowEnd);

// What a tile writes besides its points when normals are asked for (width >= 3), from its
// lattice while it is in cache: the unit normals of its inner points (3 per vertex, drawing
// order; its border points' faces are not all in its lattice) and, when `faceNormals` is given,
// the face normals (4 values per face: x, y, z, 0, as CpuEvaluator keeps them) of the quads on
// its lattice's outer ring, the ring's i-th quad at face ringFaces[i], or at i where ringFaces
// is null (row 0 of quads, then the first and last quad of each row between, then row L - 1).
template <class T>
struct TileNormals {
    T* normals = nullptr;
    T* faceNormals = nullptr;
    const std::uint32_t* ringFaces = nullptr;
};

// How the tiled form's normals split between the tile pass and the plain passes: the vertices
// whose normals the tile pass does not compute (tiles' border points, the fallback's), the
// faces that touch them that no tile's ring holds (both ascending), each tile's ring faces
// (TileNormals) from ringBegin[k], and whether the tile pass is worth it (the tiles' inner
// points are most points: listed vertices cost more each than the plain pass's).
struct TileNormalSets {
    std::vector<std::uint32_t> restVertices, restFaces, ringFaces, ringBegin;
    bool worthIt = false;
};
TileNormalSets tileNormalSets(const TiledTable& tiled);

// Tile k of a tiled table (psub/tiled.h): `base` holds level B's vertices (`width` packed
// values each), `refined` the finest level in drawing order; writes the points the tile owns
// and, with `normals.normals`, the normals above. `scratch`: tileScratchSize values. With
// `lattice`, writes instead the tile's whole (L + 1) x (L + 1) lattice there, row by row, its
// border points included (for tests).
std::size_t tileScratchSize(const TiledTable& table, std::uint32_t width);
// The instruction set the tile kernel runs with, "avx512f", "avx2" or "baseline": it is
// compiled for each and runs the best this CPU has, unless setTileKernelInstructions chose
// another (one this CPU has; false otherwise). Process-wide; for tests and benchmarks.
const char* tileKernelInstructions();
bool setTileKernelInstructions(std::string_view name);
template <class T>
void evaluateTile(const TiledTable& table, std::size_t k, const T* base, std::uint32_t width, T* refined,
                  const TileNormals<T>& normals, T* scratch, T* lattice = nullptr);

// The tiled form's output (drawing order) rearranged into the canonical order of docs/scheme.md
// (what `psub subdivide` writes): canonical[table.canonical[p]] = drawing[p].
template <class T>
void toCanonical(const TiledTable& table, std::span<const T> drawing, std::span<T> canonical, std::uint32_t width);

// PerLevel and Factorized write the canonical order; Tiled writes its drawing order (see
// psub/tiled.h; toCanonical rearranges it) and its normals follow the same order.
enum class TableForm { PerLevel, Factorized, Tiled };

// The threads a CpuEvaluator's frame of `table`'s per-level rows runs on, of `threads` (0: all
// cores): one per ~32k output values, so small meshes run on one. A caller ordering the table by
// region (orderLevelsByRegion) makes this many regions.
int perLevelFrameThreads(const PerLevelTable& table, std::uint32_t width = 3, int threads = 0);

// Control points are not checked (a frame must not pay for it). NaN or infinite control points,
// or finite ones so large that a weighted sum overflows T (for float: beyond about 1e37 for
// positions; normals take fourth powers, so beyond about 1e9), give NaN or infinite refined
// values and NaN, infinite or zero normals where they reach; never a crash, a hang or an access
// out of bounds. The psub commands refuse such input before it gets here (README, bad input).
//
// The per-frame evaluator: control points in, refined vertices out, on up to `threads`
// threads (0: all cores; fewer for small meshes, one per ~32k output values). Buffers for the
// intermediate levels are allocated once, here; a frame allocates nothing (one exception:
// normals(), below). Keeps references to the tables: they must outlive the evaluator.
template <class T>
class CpuEvaluator {
public:
    CpuEvaluator(const PerLevelTable& perLevel, const FactorizedTable& factorized,
                 const SurfaceTable& surface, TableForm form, std::uint32_t width = 3,
                 int threads = 0);
    // The tiled form: output and normals in its drawing order.
    explicit CpuEvaluator(const TiledTable& tiled, std::uint32_t width = 3, int threads = 0);

    std::uint32_t controlCount() const { return perLevel_.controlCount; }
    std::uint32_t refinedCount() const { return perLevel_.refinedCount(); }
    std::uint32_t width() const { return width_; }
    int threads() const { return threads_; }
    // The tiled form computes most normals in its tile pass (evaluate with normals, below).
    bool normalsInTilePass() const { return tileNormals_.worthIt; }
    // normals() runs as one pass over a window of face normals (windowedNormalsSimd), not two.
    bool normalsInOnePass() const { return window_.planned(); }
    // ... and reads each face's corners as 16-bit offsets (planNormalWindow), not the surface's.
    bool normalsReadNarrowCorners() const { return !window_.corners.empty(); }
    // The tiled form's normals outside its tiles' inner points (evaluate with normals, where
    // normalsInTilePass()) run as one pass too (planRestWindow), not two over lists.
    bool restNormalsInOnePass() const { return restWindow_.planned(); }
    // A normal per face of the surface is held (16 bytes a face): only for the two passes (the
    // one pass needs none; the tiled form's rest in one pass keeps only its tiles' ring faces').
    bool holdsFaceNormals() const { return !faceNormals_.empty(); }

    // control: controlCount() * width() values, packed; refined: refinedCount() * width().
    void evaluate(std::span<const T> control, std::span<T> refined);
    // The same and, when `normals` is not empty (3 * refinedCount() values; width() >= 3), the
    // refined positions' unit normals as normals() defines them. The tiled form, where its
    // tiles' inner points are most of the points, computes theirs in the tile pass (the lattice
    // still in cache; the sums of the same four face normals in another order, so within float
    // rounding of normals()) and the rest over only the faces that touch them; otherwise, and
    // the other forms, call normals() after the positions.
    void evaluate(std::span<const T> control, std::span<T> refined, std::span<T> normals);

    // Unit vertex normals (3 per vertex) of the refined surface whose positions are the first
    // three values of each `width()`-element of `refined`: area-weighted face normals summed
    // over each vertex's faces. The one call that allocates: the first, on a tiled evaluator
    // whose frames make their normals without it (restNormalsInOnePass()), allocates a normal
    // per face for its two passes.
    void normals(std::span<const T> refined, std::span<T> normals);

    // The threads' shares of a frame's rows, faces and vertices (n + 1 ascending fractions, 0 to 1:
    // thread t of a team of n takes from rowShareStart(count, bounds, t, n) on), moved after each
    // frame toward the threads' speeds (balanceRowShares); empty before the first frame. A team of
    // another size starts from even shares. setRowShares starts them from `bounds` instead
    // (throws std::invalid_argument unless they are such fractions): for a caller that knows its
    // threads' speeds, and for the tests, which move the shares both ways.
    std::span<const double> rowShares() const { return rowBounds_; }
    void setRowShares(std::span<const double> bounds);

    // The table bytes a frame reads less than the table holds: those the narrow copy stands in
    // for (narrowBytesSaved; 0 where it has none).
    std::uint64_t narrowBytesSaved() const { return psub::narrowBytesSaved(perLevel_, narrow_); }

private:
    // The two passes of normals(), run by each thread of its team on its share (by the rows'
    // fractions, rowBounds_, where the team is theirs): of every face and vertex, or (`only`
    // not null) of the listed ones.
    void faceNormalsScalar(const T* positions, const std::vector<std::uint32_t>* only = nullptr);
    void vertexNormalsScalar(T* normals, const std::vector<std::uint32_t>* only = nullptr) const;
    void faceNormalsSimd(const T* positions, const std::vector<std::uint32_t>* only = nullptr);  // float only
    void vertexNormalsSimd(T* normals, const std::vector<std::uint32_t>* only = nullptr) const;  // float only
    // The plan of one pass over a window of face normals: vertices (all, or a list) in blocks of
    // kWindowBlock, and the faces they read as a stream, each block's computed just before it
    // into a window of kWindowFaces slots in cache (a face read again far on comes twice).
    struct NormalWindow {
        std::vector<std::uint32_t> vertices;  // the listed vertices, ascending (empty: every vertex)
        // Per listed vertex where its entries begin in `slots`, and the end (empty: the
        // surface's vertexOffsets, the stream its faces in order).
        std::vector<std::uint32_t> entries;
        // Per block: the first stream face it or any later block reads; one past the last it reads.
        std::vector<std::uint32_t> from, to;
        std::vector<std::uint32_t> lastVertexFaces;  // stream faces around the surface's last vertex, ascending
        std::vector<std::uint16_t> slots;            // per entry: 2 x its face's window slot
        // Per stream face corner 3 x (the vertex less cornerBase of its run of kCornerRun faces):
        // its offset in floats (empty where a run's corners span more than 21,845 vertices).
        std::vector<std::uint16_t> corners;
        std::vector<std::uint32_t> cornerBase;
        // Else the stream's corners (empty: the surface's faceVerts); a listed plan's (the tiled
        // form's rest) mark the tiles' ring faces (kRingFace), whose normals the tile pass made.
        std::vector<std::uint32_t> wideCorners;
        std::vector<std::uint8_t> fourFaceBlocks;  // per block: its vertices have 4 faces each
        std::vector<std::uint64_t> work;  // per block, the work up to its end (empty: blocks weigh the same)
        bool planned() const { return !to.empty(); }
    };
    // One pass of normals (float, SSE, quads, width 3) by plan `w`: each thread's blocks in
    // turn; the same operations as the two passes, so the same bits.
    void windowedNormalsSimd(const T* positions, T* normals, const NormalWindow& w) const;
    void planNormalWindow();  // window_: every vertex, the faces in the surface's order
    void planRestWindow();    // restWindow_: the tiled form's rest vertices
    // w's narrow corners from the stream's `corners` (4 per face), where they fit.
    void planNarrowCorners(NormalWindow& w, const std::uint32_t* corners, std::size_t faces) const;
    // Both passes, inside a parallel region (a barrier between them).
    void normalPasses(const T* positions, T* normals, const std::vector<std::uint32_t>* faces = nullptr,
                      const std::vector<std::uint32_t>* vertices = nullptr);
    void allocate();                             // buffers of the constructors
    void makeNarrowRows();                       // narrow_, of the groups whose rows read it
    RowReads rowReads(std::size_t level) const;  // how level `level`'s rows read
    void needFaceNormals();                      // faceNormals_, for the two passes (once)
    void evaluateTiled(std::span<const T> control, std::span<T> refined, T* normals, int team);

    const PerLevelTable& perLevel_;
    const FactorizedTable& factorized_;
    const SurfaceTable& surface_;
    TableForm form_;
    std::uint32_t width_;
    int threads_;
    std::vector<T> levels_;                 // intermediate levels, back to back
    std::vector<std::uint64_t> levelBase_;  // offset of each intermediate level in levels_
    // No readsOwnLevel row of the finest level reads its last vertex, so they may read
    // every vertex of the output 16 bytes at a time (finestOwnReadsWide).
    bool finestOwnReadsWide_ = false;
    NarrowRows narrow_;  // the rows' narrow indices (float, width 3; else empty)
    std::vector<T> faceNormals_;  // 4 per face, the 4th 0 (empty until the two passes first run)
    std::vector<T> ringNormals_;  // the tiles' ring faces' normals, 4 each in ringFaces order (restWindow_)
    bool allQuads_ = false;       // every face of the surface a quad: faceOffsets[f] == 4 f
    // The normal passes prefetch the positions and face normals they will gather: worth it in
    // the canonical order (the cow at 7 steps, per-level: normals 7.2-8.0 ms against 9.5-9.9
    // without), not in the tiled form's drawing order, whose neighbours are near in memory
    // already (3.5-4.0 against 4.1-4.3 ms with; session 26, bench/README.md).
    bool prefetchNormals_ = true;
    NormalWindow window_;      // normals() in one pass (planNormalWindow; not planned: two passes)
    NormalWindow restWindow_;  // the tiled form's rest in one pass (planRestWindow)
    const TiledTable* tiled_ = nullptr;
    // The threads' shares of a frame's rows (fractions: thread t's from rowBounds_[t] to
    // rowBounds_[t + 1]), moved after each frame toward how fast each thread ran its rows, and
    // the seconds each spent on them in the frame (every 8th value; compute/cpu_evaluator.cpp).
    std::vector<double> rowBounds_;
    std::vector<double> rowSeconds_;
    TileNormalSets tileNormals_;  // tiled form: normals in the tile pass, where worthIt
};

// Refines a face-varying channel (psub/tables.h) on the calling thread: `control` holds
// table.perLevel.controlCount values of table.width each, `refined` table.valueCount(). UVs
// usually do not change from frame to frame: call this when they do, not every frame.
template <class T>
void evaluateFaceVarying(const FaceVaryingTable& table, std::span<const T> control, std::span<T> refined);

extern template class CpuEvaluator<float>;
extern template class CpuEvaluator<double>;

}  // namespace psub
