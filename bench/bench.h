// psub/bench: `psub bench`, PSub against OpenSubdiv in the same run on the same machine.
// For each model and each matched size (P-S levels with the face count of Catmull-Clark level
// k), it times building (topology + stencil tables) and per-frame evaluation of animated
// control points, measures the machine's memory bandwidth (STREAM-style triad), and writes a
// markdown table (stdout), JSON (--json) and an SVG plot (--plot). Timings live here, never
// in tests.
#pragma once

#include "psub/topology.h"

#include <cstdint>
#include <string>
#include <vector>

namespace psub::bench {

struct BenchOptions {
    std::vector<std::string> models;  // OBJ paths; empty: the bundled models plus the torus
    std::string dataDir;              // where the bundled models live (cow, spot, cube)
    std::string jsonPath;             // empty: no JSON
    std::string plotPath;             // empty: no plot
    int frames = 30;                  // timed frames per configuration, after warm-up
    int warmup = 3;                   // untimed frames first
    bool quick = false;               // smallest size per model only, few frames (smoke test)
    int levels = 3;                   // Catmull-Clark levels 1..levels ...
    std::uint64_t extendBelow = 200000;   // ... and more while CC faces stay at most this
    std::uint64_t maxFaces = 20000000;    // no size whose refined face count exceeds this
    std::uint64_t maxFactorizedFaces = 5000000;  // PSub's factorized table only up to this (memory)
    int torus = 512;                  // the generated torus has torus x torus quads; 0: none
    double frameBudgetSeconds = 6;    // per configuration: fewer frames (>= 10) beyond this
    int coldFrames = 3;               // frames timed each after the caches are flushed (0: none)
    std::string command;              // the command line, written next to the results
};

// Runs the benchmark; returns the process exit status (0, or 1 when a model cannot be read).
// Throws InputError for an unreadable or invalid model.
int runBench(const BenchOptions& options);

// A closed torus of n x n quads (n >= 3), major radius 1, minor radius 0.4, faces
// counter-clockwise seen from outside (positive volume).
Mesh makeTorus(int n);

// The mesh a benchmark program names on its command line: "torus:N", the generated N x N torus
// (N from 3 to 9999, else InputError), or an OBJ file.
Mesh benchMesh(const std::string& name);

// A command-line number of a benchmark program: the whole of `text` a decimal in [lo, hi] (an
// integer when `whole`), else a one-line error naming `what` on stderr and exit status 2.
double parseArgument(const char* text, const char* what, double lo, double hi, bool whole = true);

}  // namespace psub::bench
