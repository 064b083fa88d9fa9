// The psub commands, each a plain function over parsed options (see main.cpp for the CLI).
#pragma once

#include "psub/animation.h"
#include "psub/rules.h"
#include "psub/stencils.h"
#include "psub/topology.h"

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace psub::cli {

enum class Scheme { PS, CatmullClark };

// Where subdivide evaluates the stencils: the CPU (double), a Vulkan device (float), or
// Vulkan when a device is usable and the CPU otherwise (with a message on stderr).
enum class Backend { Cpu, Vulkan, Auto };

struct SubdivideOptions {
    std::string input, output;
    int levels = 1;
    Scheme scheme = Scheme::PS;
    Preprocess preprocess = Preprocess::Auto;
    Rules rules = Rules::Paper;
    Boundary boundary = Boundary::Paper;
    Backend backend = Backend::Cpu;
    std::uint64_t maxMemory = 0;  // bytes; 0 = default (3/4 of physical memory)
    UvLinear uvLinear = UvLinear::Boundaries;  // texture coordinates (docs/face-varying.md)
    std::optional<double> at;     // glTF input: pose clip `animation` at these seconds (clamped)
    std::string animation;        // glTF input: the clip --at poses; empty: the first
};

// .gltf or .glb (either case): read with readGltf, written with formatGltf.
bool isGltfPath(const std::string& path);

struct StatsOptions {
    std::string input;
    int levels = 4;
    Preprocess preprocess = Preprocess::Auto;
    std::uint64_t maxMemory = 0;
};

struct DemoOptions {
    std::string model;      // empty: the bundled cow
    int levels = 4;
    std::string outputDir;  // empty: write nothing
};

// Each returns the process exit status; bad input throws InputError (exit 1 in main).
int runSubdivide(const SubdivideOptions& options);
int runStats(const StatsOptions& options);
int runDemo(const DemoOptions& options);

// Reads and checks an OBJ file (throws InputError), printing its warnings on stderr.
Mesh loadChecked(const std::string& path, CheckedMesh& checked);

// Where the bundled models live: $PSUB_DATA_DIR, else the source tree's data/, else
// <prefix>/share/psub next to the installed program.
std::string dataDir();

// ---- Shared by the commands' own files (commands.cpp, demo.cpp, play.cpp, view.cpp)

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point start);

// A checked input mesh and why OpenSubdiv cannot refine it (then P-S only).
struct Loaded {
    Mesh mesh;
    CheckedMesh checked;
    std::optional<std::string> ccProblem;  // why OpenSubdiv cannot refine it (then P-S only)
    std::optional<GltfMaterial> material;  // glTF input with a material
};
// An OBJ or glTF file, checked; a glTF cage in its static pose, or clip `animation` (default
// the first) at `at` seconds.
Loaded load(const std::string& path, std::optional<double> at = {}, const std::string& animation = {});

// The comment at the top of a written OBJ file.
std::string header(const std::string& input, const std::string& what);

// Prints P-S levels then Catmull-Clark levels with the face counts P-S reaches (up to `maxFaces`).
void printStats(const Loaded& loaded, const Hierarchy& hierarchy, const std::vector<double>& levelMs,
                std::uint64_t maxFaces);

// The tiled form's lean build with no tile (TileSides::None): the third tiled candidate that
// fasterForm (evaluators.h) times for psub play and psub view.
TiledTable tiledWithoutTiles(const Mesh& mesh, const Connectivity& connectivity, int levels, Rules rules,
                             Boundary boundary);

}  // namespace psub::cli
