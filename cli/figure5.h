// psub figure5: the paper's Figure 5 (P-S beside Catmull-Clark at equal face counts, one PNG
// row per bundled model) and its Table I (faces per step, printed and plotted).
#pragma once

#include "commands.h"

#include <cstdint>
#include <string>

namespace CLI {
class App;
}

namespace psub::cli {

struct Figure5Options {
    std::string outputDir = ".";
    std::uint32_t panelWidth = 480, panelHeight = 360;
};

// Adds `psub figure5` to `app`, parsing into `options`; returns the subcommand.
CLI::App* addFigure5Command(CLI::App& app, Figure5Options& options);

// Writes figure5_cow.png, figure5_cube.png and table1.png and prints Table I. Returns 0, or 1
// with one line on stderr (no Vulkan device, a file that cannot be written).
int runFigure5(const Figure5Options& options);

// psub figure-shape: figure_shape_cube.png, the cube after 4 P-S steps with --rules paper and
// --rules shape beside Catmull-Clark after 2 levels (96 faces each, one camera). Returns as runFigure5.
CLI::App* addFigureShapeCommand(CLI::App& app, Figure5Options& options);
int runFigureShape(const Figure5Options& options);

}  // namespace psub::cli
