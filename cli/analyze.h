// The analysis commands: psub analyze (smoothness per valence), psub compare (P-S against
// Catmull-Clark on a model), and the demo's verdict table. Parsed in main.cpp.
#pragma once

#include "psub/topology.h"

#include <cstdint>
#include <string>
#include <vector>

namespace psub::cli {

struct AnalyzeOptions {
    std::string valences = "2..16";  // "A..B", "N" or a comma list of both
    std::string rules = "both";      // paper, robust, shape, both (paper, robust) or all
    bool json = false;
    int rings = 8;    // characteristic map's control net
    int levels = 10;  // two-step levels of the tangent-plane check
    std::string boundaryModel;  // set: report boundary triangle shapes of this mesh instead
    int boundaryLevels = 11;    // P-S steps of that report
    bool optimizeShape = false;  // set: search Rules::Shape's weights at each valence instead
    double minimumGap = 0.12;    // of that search (see psub/analysis.h)
    double maximumSpread = 30;   // degrees, of that search
    bool shapeTradeoff = false;  // set: the n = 3 trade-off beyond the vertex weights instead
};

struct CompareOptions {
    std::string input;
    int levels = 2;                 // P-S steps (even); Catmull-Clark gets half
    std::string rules = "paper";
    Boundary boundary = Boundary::Paper;
    std::string plot;               // PNG path; empty: no plot
    int samples = 2;                // sample intervals per triangle edge
    bool json = false;
};

// "2..16", "5", "2,3,8..10" -> valences; throws InputError on anything else or a valence
// outside 2..64.
std::vector<Index> parseValences(const std::string& text);

// Each returns the process exit status; bad input throws InputError (exit 1 in main).
int runAnalyze(const AnalyzeOptions& options);
int runCompare(const CompareOptions& options);

// The demo's verdict table (claim, measured, holds?) for a checked model refined `levels`
// P-S steps (even: Catmull-Clark gets half; odd: one less).
void printVerdicts(const Mesh& mesh, const Connectivity& connectivity, int levels);

}  // namespace psub::cli
