// psub render: a refined mesh drawn offscreen with Vulkan into a PNG (psub_render). Its
// options, its CLI11 subcommand, and the command itself; main.cpp only registers it.
#pragma once

#include "commands.h"

#include "psub/render.h"

#include <cstdint>
#include <string>

namespace CLI {
class App;
}

namespace psub::cli {

struct RenderCommandOptions {
    std::string input, output;
    int levels = 4;
    Scheme scheme = Scheme::PS;
    Wireframe wireframe = Wireframe::None;
    std::uint32_t width = 1280, height = 720;
    Backend backend = Backend::Cpu;  // where the surface is evaluated: Cpu or Vulkan
    int frames = 1;                  // draws timed (the last one is written)
};

// Adds `psub render` to `app`, parsing into `options`; returns the subcommand.
CLI::App* addRenderCommand(CLI::App& app, RenderCommandOptions& options);

// Returns the exit status: 0, or 1 with one line on stderr (no Vulkan device, unwritable
// output). Bad input throws InputError (exit 1 in main).
int runRender(const RenderCommandOptions& options);

}  // namespace psub::cli
