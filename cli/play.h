// psub play: real-time animation playback. A control mesh deformed every frame (procedural
// wave/twist/bend, or a glTF clip), refined through the stencil tables on the CPU or with
// Vulkan, normals computed, optionally drawn offscreen; per-stage times per frame.
#pragma once

#include "commands.h"

#include <cstdint>
#include <string>

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
    bool verify = false;        // compare each frame with the rule oracle from scratch
    bool json = false;
};

// Adds `psub play` to `app`, parsing into `options`; returns the subcommand.
CLI::App* addPlayCommand(CLI::App& app, PlayOptions& options);

// Returns the exit status: 0; 1 with one line on stderr (no Vulkan device for --backend
// vulkan or --render, a frame that fails --verify, an unwritable frame). Bad input throws
// InputError (exit 1 in main).
int runPlay(const PlayOptions& options);

}  // namespace psub::cli
