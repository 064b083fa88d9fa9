// psub play: real-time animation playback. A control mesh deformed every frame (procedural
// wave/twist/bend, or a glTF clip), refined through the stencil tables on the CPU or with
// Vulkan, normals computed, optionally drawn offscreen; per-stage times per frame.
#pragma once

#include "commands.h"

#include "psub/animation.h"
#include "psub/topology.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace psub::cli {

struct PlayOptions {
    std::string input;          // .obj, or .gltf / .glb (skinning, morph targets, clips)
    int levels = 3;             // P-S steps
    int frames = 120;
    std::string animation;      // wave, twist, bend, or a glTF clip's name; empty: the default
    double animationFps = 30;   // animation time advanced per frame: 1 / animationFps seconds
    Backend backend = Backend::Cpu;
    Rules rules = Rules::Paper;
    Boundary boundary = Boundary::Paper;
    std::string renderDir;      // set: draw every frame and write DIR/frame_NNNN.png
    std::uint32_t width = 1280, height = 720;
    int wireframe = 0;          // 0 none, 1 refined, 2 control (psub::Wireframe)
    std::uint32_t samples = 4;  // MSAA samples per pixel of --render
    std::string texture;        // with --render: base-colour image sampled with the mesh's UVs
    bool verify = false;        // compare each frame with the rule oracle from scratch
    bool json = false;
    int form = 0;               // table form (either backend): 0 auto, 1 per-level, 2 factorized, 3 tiled (kPlayForms)
};

// The animated control mesh (also psub view's).
struct Animated {
    Mesh mesh;
    CheckedMesh checked;
    std::unique_ptr<GltfAsset> asset;  // the player keeps a reference: heap, never moved
    std::unique_ptr<GltfPlayer> player;
    std::size_t clip = 0;
    std::optional<Procedural> procedural;
    RestBounds bounds;
    std::vector<float> rest;  // the pose procedural deformers start from
    std::string name;         // what plays, for the report
    double period = kProceduralPeriod;

    // The control points at `seconds`; allocates nothing.
    void pose(double seconds, std::span<float> out) {
        if (procedural) deformProcedural(*procedural, bounds, rest, seconds, out);
        else player->pose(clip, seconds, out);
    }
};

// Loads options.input (OBJ or glTF) and the animation options.animation names (empty: a glTF
// file's first clip, else wave), checked; warnings on stderr. Bad input throws InputError.
Animated loadAnimated(const PlayOptions& options);

// Adds `psub play` to `app`, parsing into `options`; returns the subcommand.
CLI::App* addPlayCommand(CLI::App& app, PlayOptions& options);

// Returns the exit status: 0; 1 with one line on stderr (no Vulkan device for --backend
// vulkan or --render, a frame that fails --verify, an unwritable frame). Bad input throws
// InputError (exit 1 in main).
int runPlay(const PlayOptions& options);

}  // namespace psub::cli
