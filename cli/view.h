// psub view: the animated, refined surface in a window (GLFW + Vulkan swapchain), with orbit,
// zoom and pan, keys for level, scheme, wireframe, playback, boundary and rules, a HUD, and a
// script mode (events at frame numbers, screenshot, per-frame JSON log) for tests.
#pragma once

#include "commands.h"

#include <cstdint>
#include <string>

namespace CLI {
class App;
}

namespace psub::cli {

struct ViewOptions {
    std::string input;          // .obj, or .gltf / .glb
    int levels = 3;             // P-S steps
    int scheme = 0;             // 0 P-S, 1 Catmull-Clark (OpenSubdiv), 2 both side by side
    std::string animation;      // wave, twist, bend, or a glTF clip; empty: psub play's default
    Backend backend = Backend::Cpu;
    Rules rules = Rules::Paper;
    Boundary boundary = Boundary::Paper;
    int form = 0;               // P-S table form: 0 auto (psub play's), 1 per-level, 2 tiled
    std::uint32_t width = 1280, height = 720;
    std::uint32_t samples = 4;  // MSAA, as psub render
    int wireframe = 0;          // 0 none, 1 refined, 2 control
    bool noVsync = false;
    bool noHud = false;
    bool paused = false;
    int frames = 0;             // > 0: exit 0 after this many frames
    int framesInFlight = 2;     // 2: frame n+1 is evaluated while frame n is drawn; 1: one after the other
    double step = 0;            // > 0: the animation advances this many seconds per frame (not wall clock)
    std::string script;         // events at frame numbers
    std::string screenshot;     // PNG of the last frame's swapchain image
    std::string log;            // one JSON line per frame
};

// Adds `psub view` to `app`, parsing into `options`; returns the subcommand.
CLI::App* addViewCommand(CLI::App& app, ViewOptions& options);

// Returns the exit status: 0 (Esc, window closed, or --frames reached); 1 with one line on
// stderr (no display, no Vulkan device that can present, unwritable output). Bad input (model,
// script) throws InputError (exit 1 in main).
int runView(const ViewOptions& options);

}  // namespace psub::cli
