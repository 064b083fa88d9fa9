// psub: the command-line program. Parses arguments (CLI11) and maps outcomes to exit codes:
// 0 success, 1 bad input (one line on stderr), 2 usage error.
#include "analyze.h"
#include "options.h"
#include "play.h"
#include "bench.h"
#include "commands.h"
#include "psub/output.h"
#if PSUB_HAVE_RENDER
#include "figure5.h"
#include "render.h"
#endif
#if PSUB_HAVE_VIEW
#include "view.h"
#endif

#include <CLI/CLI.hpp>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <limits>
#include <map>

namespace {

using namespace psub;
using namespace psub::cli;

const std::map<std::string, Preprocess> kPreprocess = {
    {"auto", Preprocess::Auto}, {"always", Preprocess::Always}, {"never", Preprocess::Never}};
const std::map<std::string, Backend> kBackend = {
    {"cpu", Backend::Cpu}, {"vulkan", Backend::Vulkan}, {"auto", Backend::Auto}};

// Levels are capped so closed-form counts stay in 64 bits; the memory guard stops far sooner.
constexpr int kMaxLevels = 30;
// Face-count options of psub bench: refined meshes are indexed in 32 bits.
constexpr long long kMaxBenchFaces = 4294967295LL;

void addPreprocess(CLI::App* command, Preprocess& target) {
    addChoice(command, "--preprocess", target, kPreprocess,
              "auto: apply the paired method when a face is not a quad (triangles on the "
              "boundary are legal P-S input); always; never (error if it is needed)",
              "auto");
}

void addMaxMemory(CLI::App* command, std::uint64_t& target) {
    addBytes(command, "--max-memory", target,
             "refuse work estimated to need more bytes than this (suffixes K M G T, powers of 1024; "
             "default 3/4 of physical memory)");
}

// Edit distance (insertions, deletions, substitutions) between two words.
std::size_t editDistance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t above = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = above;
        }
    }
    return row[b.size()];
}

// A first argument that is not an option and names no subcommand: the list of subcommands
// and the closest one, as a usage error. Empty when `word` is a subcommand.
std::string unknownCommandMessage(const CLI::App& app, const std::string& word) {
    std::string names, closest;
    std::size_t best = std::string::npos;
    for (const CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; })) {
        const std::string& name = command->get_name();
        if (name == word) return {};
        names += (names.empty() ? "" : ", ") + name;
        const std::size_t distance = editDistance(word, name);
        if (distance < best) best = distance, closest = name;
    }
    std::string message = "psub: unknown command '" + word + "'";
    if (best <= std::max<std::size_t>(2, word.size() / 3)) message += " (did you mean '" + closest + "'?)";
    return message + "; the commands are " + names + ". Run 'psub --help' for more.";
}

// Runs the parsed command; then standard output must have been written completely.
template <class Run>
int runAndFinish(Run&& run) {
    const int status = run();
    if (status == 0) finishStdout();
    return status;
}

// Refinement builds each level's arrays (megabytes each) and frees its parent's. With glibc's
// defaults the larger ones are mapped and unmapped every time and the heap is trimmed after
// each free, so every level's arrays start as fresh pages, each one a page fault: refining the
// 1M-face torus spent about a third of its build faulting pages. Allocations of up to 32 MiB
// come from the heap instead, which is not given back, so the next level reuses the pages the
// last one freed: the per-level build of the 1M-face torus 115-154 -> 93-107 ms (bench/README.md
// "Session 14"), for a peak 3% higher (the cow at 7 steps 335 -> 345 MiB; the memory guard's
// estimate allows for it). The heap grows 64 MiB at a time, so that cli/huge_pages.cpp can
// advise huge pages for what it has not touched yet.
void tuneAllocator() {
#if defined(__GLIBC__)
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
    mallopt(M_TOP_PAD, 64 << 20);
#endif
}

}  // namespace

int main(int argc, char** argv) {
    // A file-size limit (ulimit -f) must fail the write with an error, not kill the program.
    std::signal(SIGXFSZ, SIG_IGN);
    tuneAllocator();
    CLI::App app{"psub: P-S (Liu-Yang-Guan) subdivision surfaces, with OpenSubdiv's "
                 "Catmull-Clark beside them for comparison."};
    app.require_subcommand(1);
    app.footer("Run 'psub COMMAND --help' for a command's options and an example.\n"
               "Exit status: 0 success, 1 bad input, 2 usage error.");

    SubdivideOptions subdivide;
    CLI::App* sub = app.add_subcommand("subdivide", "Refine a mesh and write it as OBJ or glTF");
    sub->add_option("input", subdivide.input,
                    "input mesh: .obj, or .gltf / .glb (its mesh posed in world space, UVs and base colour material)")
        ->required();
    sub->add_option("-o,--output", subdivide.output,
                    "output mesh, written atomically: .glb or .gltf (self-contained: positions, normals, UVs, the "
                    "material and its texture), else OBJ; - for OBJ on standard output")
        ->required();
    double subdivideAt = 0;
    addReal(sub, "--at", subdivideAt, 0, 1e9,
            "glTF input: pose the clip (--anim, default the first) at this many seconds (clamped to the clip) "
            "before refining; without it, the rest pose",
            0);
    sub->add_option("--anim", subdivide.animation, "glTF input with --at: the name of the clip to pose");
    addInteger(sub, "-l,--levels", subdivide.levels, 0, kMaxLevels,
               "refinement steps (P-S steps after any preprocessing; 0 writes the preprocessed mesh)", 1);
    addChoice(sub, "--scheme", subdivide.scheme, kSchemeNames,
              "ps: P-S; cc: Catmull-Clark through OpenSubdiv (edge-only boundary, no creases)", "ps");
    addPreprocess(sub, subdivide.preprocess);
    addChoice(sub, "--rules", subdivide.rules, kRulesNames,
              "paper: docs/scheme.md exactly; robust (beyond the paper): interior valence 2 gets c, d, e = "
              "0, 1/3, 1/6 instead of the paper's folding -1/2, 1/2, 1/4; shape (beyond the paper): robust, and "
              "centre weights at valence 3 and 5..16 that keep more of the shape, C1 kept (--scheme ps only)",
              "paper");
    addChoice(sub, "--boundary", subdivide.boundary, kBoundaryNames,
              "paper: docs/scheme.md exactly, the boundary is never refined (its triangles grow thin); "
              "smooth (beyond the paper): every second step splits the boundary edges with cubic "
              "B-spline rules, so after 2k steps the boundary is Catmull-Clark's after k (--scheme ps only)",
              "paper");
    addChoice(sub, "--backend", subdivide.backend, kBackend,
              "where the stencils are evaluated: cpu (double); vulkan (float, on the device chosen by "
              "capability or $PSUB_VULKAN_DEVICE; exit 1 without one); auto (vulkan when a device is "
              "usable, else the CPU with a message)",
              "cpu");
    addMaxMemory(sub, subdivide.maxMemory);
    addChoice(sub, "--uv-linear", subdivide.uvLinear, kUvLinearNames,
              "texture coordinates (vt), docs/face-varying.md: boundaries: P-S rules in the interior, seam "
              "and boundary polylines kept; all: linear everywhere (--scheme ps only)",
              "boundaries");
    sub->footer("Example:\n  psub subdivide data/cow.obj -o cow_ps4.obj --levels 4\n"
                "  psub subdivide data/cow.obj -o cow_cc2.obj --levels 2 --scheme cc\n"
                "  psub subdivide data/grid4x4.obj -o grid_smooth.obj --levels 4 --boundary smooth\n"
                "  psub subdivide data/two_bone_cylinder.glb -o bent.glb --levels 3 --at 0.5\n"
                "Vertex order (docs/scheme.md): children of old vertices first, then one vertex per "
                "old face (then, --boundary smooth, one per split boundary edge, in edge order).");

    StatsOptions stats;
    CLI::App* st = app.add_subcommand("stats", "Count vertices, edges, faces per level, P-S beside Catmull-Clark");
    st->add_option("input", stats.input, "input mesh (.obj)")->required();
    addInteger(st, "-l,--levels", stats.levels, 0, kMaxLevels, "P-S steps to count", 4);
    addPreprocess(st, stats.preprocess);
    addMaxMemory(st, stats.maxMemory);
    st->footer("Example:\n  psub stats data/cube.obj --levels 6");

    DemoOptions demo;
    CLI::App* de = app.add_subcommand("demo", "A first look: the bundled cow under P-S and Catmull-Clark");
    de->add_option("--model", demo.model, "another mesh instead of the bundled cow");
    addInteger(de, "-l,--levels", demo.levels, 1, 8, "P-S steps (Catmull-Clark gets half as many)", 4);
    de->add_option("-o,--output-dir", demo.outputDir, "also write the refined meshes here")
        ->check(CLI::ExistingDirectory);
    de->footer("Example:\n  psub demo\n  psub demo --output-dir /tmp --levels 2");

    AnalyzeOptions analyze;
    CLI::App* an = app.add_subcommand(
        "analyze", "Smoothness per valence from the engine's own stencils: eigenvalues, C1, characteristic map");
    an->add_option("--valence", analyze.valences, "valences: A..B, N, or a comma list of both (2..64)")
        ->check(CLI::Validator(
            [](std::string& value) {
                try {
                    parseValences(value);
                } catch (const InputError& e) {
                    return std::string(e.what());
                }
                return std::string();
            },
            "VALENCES"))
        ->default_val("2..16");
    an->add_option("--rules", analyze.rules,
                   "paper, robust (beyond the paper: valence 2 fixed), shape (beyond the paper: keeps the shape at "
                   "low valence), both (paper and robust) or all")
        ->check(CLI::IsMember({"paper", "robust", "shape", "both", "all"}))->default_val("both");
    an->add_flag("--json", analyze.json,
                 "a JSON array, one record per (valence, rules): n, rules, eigenvalues (the leading 6, "
                 "descending by modulus, each [re, im]), c1_necessary, characteristic_map_injective, "
                 "cc_lambda1, and more");
    addInteger(an, "--rings", analyze.rings, 4, 10, "control rings of the characteristic map check", 8);
    addInteger(an, "--tangent-levels", analyze.levels, 1, 40, "two-step levels of the tangent-plane check", 10);
    an->add_option("--boundary-aspect", analyze.boundaryModel,
                   "instead: the shape of the triangles along this mesh's boundary after each P-S step, "
                   "--boundary paper beside smooth");
    an->add_flag("--optimize-shape", analyze.optimizeShape,
                 "instead: search the shape rules' centre weights per valence (--valence, from 3) and print "
                 "them as a table and as rules.cpp's array");
    addReal(an, "--min-gap", analyze.minimumGap, 0.0, 1.0,
            "--optimize-shape: least lambda1 - |lambda3| (or the paper's, if less)", 0.12);
    addReal(an, "--max-spread", analyze.maximumSpread, 0.0, 180.0,
            "--optimize-shape: largest normal spread (degrees) after 10 two-step levels", 30);
    an->add_flag("--shape-tradeoff", analyze.shapeTradeoff,
                 "instead: at valence 3, the cube's best volume ratio per least spectral gap with F-vertex and "
                 "edge-neighbour weights beside c, d, e; --rules shape's corner rule is one of its points (docs/shape-rules.md)");
    addInteger(an, "--boundary-levels", analyze.boundaryLevels, 1, 16, "P-S steps of --boundary-aspect", 11);
    an->footer("For an interior vertex of valence n surrounded by quads, builds the two-step P-S matrix from the\n"
               "engine's stencil tables, and Catmull-Clark's from OpenSubdiv's. The paper's rules fail C1 at\n"
               "valence 2; --rules robust passes.\n"
               "Examples:\n  psub analyze --valence 2..16\n  psub analyze --valence 2 --rules both\n"
               "  psub analyze --valence 3,5 --rules paper --json\n"
               "  psub analyze --boundary-aspect data/grid4x4.obj --boundary-levels 11");

    CompareOptions compare;
    CLI::App* co = app.add_subcommand(
        "compare", "P-S after 2k steps against Catmull-Clark after k: volume, area, box, Hausdorff distance");
    co->add_option("input", compare.input, "input mesh (.obj)")->required();
    addInteger(co, "-l,--levels", compare.levels, 0, 12, "P-S steps, even (Catmull-Clark gets half as many)", 2)
        ->check(CLI::Validator(
                                        [](std::string& value) {
                                            const bool odd = !value.empty() && std::string("13579").find(value.back()) != std::string::npos;
                                            return odd ? std::string("must be even") : std::string();
                                        },
                                        "EVEN"));
    co->add_option("--rules", compare.rules, "P-S rules: paper, robust or shape (both beyond the paper)")
        ->check(CLI::IsMember({"paper", "robust", "shape"}))->default_val("paper");
    addChoice(co, "--boundary", compare.boundary, kBoundaryNames,
              "paper: the boundary is never refined; smooth (beyond the paper): split every second step, "
              "so the boundary is Catmull-Clark's",
              "paper");
    co->add_option("--plot", compare.plot, "also draw the comparison as a PNG here (ratios and distance histograms)");
    addInteger(co, "--samples", compare.samples, 1, 16, "sample intervals per triangle edge for the distances", 2);
    co->add_flag("--json", compare.json, "print the numbers as one JSON object");
    co->footer("Distances: points sampled on every face of one mesh, nearest point on the other's triangles,\n"
               "both ways; Hausdorff is the larger maximum. P-S comes from the engine's tables (after the\n"
               "paired method when the input is not quads), Catmull-Clark from OpenSubdiv.\n"
               "Examples:\n  psub compare data/cube.obj --levels 4 --plot cube.png\n"
               "  psub compare data/cow.obj --levels 4 --json");

    bench::BenchOptions benchOptions;
    CLI::App* be = app.add_subcommand(
        "bench", "Time PSub against OpenSubdiv on this machine, same run: build, per frame, bandwidth");
    be->add_option("models", benchOptions.models,
                   "models (.obj) to measure instead of the defaults (the bundled cow, Spot and cube "
                   "plus a generated torus); torus:N generates an N x N quad torus");
    be->add_option("--json", benchOptions.jsonPath, "also write every measurement as JSON here");
    be->add_option("--plot", benchOptions.plotPath, "also draw per-frame time against refined faces (SVG)");
    addInteger(be, "--frames", benchOptions.frames, 1, 1000000, "timed frames per configuration", 30);
    addInteger(be, "--warmup", benchOptions.warmup, 0, 1000, "untimed frames before them", 3);
    addReal(be, "--frame-budget", benchOptions.frameBudgetSeconds, 0.001, 86400,
            "seconds per configuration: beyond it, fewer frames (at least 10) are timed", 6);
    addInteger(be, "--cold-frames", benchOptions.coldFrames, 0, 1000,
               "then frames timed each after writing twice the last-level cache (256 MB to 1 GB): the frame "
               "when the caches hold nothing of the last one",
               3);
    be->add_flag("--quick", benchOptions.quick, "smallest size per model, 5 frames and 1 cold one (a smoke test)");
    addInteger(be, "-l,--levels", benchOptions.levels, 1, 10,
               "Catmull-Clark levels 1..N (small models go on while they have at most --extend-below faces)", 3);
    addInteger(be, "--extend-below", benchOptions.extendBelow, 0, kMaxBenchFaces,
               "keep adding levels beyond --levels while the refined mesh has at most this many faces",
               decltype(benchOptions.extendBelow)(200000));
    addInteger(be, "--max-faces", benchOptions.maxFaces, 1, kMaxBenchFaces,
               "skip sizes with more refined faces than this", decltype(benchOptions.maxFaces)(20000000));
    addInteger(be, "--max-factorized-faces", benchOptions.maxFactorizedFaces, 0, kMaxBenchFaces,
               "build PSub's factorized table only up to this many refined faces (it grows with "
               "the levels: about 350 B per vertex at 6 P-S levels)",
               decltype(benchOptions.maxFactorizedFaces)(5000000));
    addInteger(be, "--torus", benchOptions.torus, 0, 4096,
               "the generated torus has N x N quads (0: none); only with the default models", 512)
        ->check(CLI::Validator(
            [](std::string& value) {
                long long n = 0;
                parseInteger(value, 0, 4096, n);
                return n == 0 || n >= 3 ? std::string() : std::string("expected 0 or 3..4096");
            },
            ""));
    be->footer(
        "What is measured, per model and per matched size (P-S levels with the face count of "
        "Catmull-Clark level k):\n"
        "  build      psub::refine (topology + per-level table, + factorized table; the tiled rows: topology +\n"
        "             the tiled table alone, its lean build, for drawing: no canonical order, which the\n"
        "             JSON's build_with_canonical_order_ms adds back) against OpenSubdiv's\n"
        "             TopologyRefinerFactory + RefineUniform + StencilTableFactory (factorized, cascading)\n"
        "  per frame  median and min of --frames frames of moving control points: psub-cpu-perlevel and\n"
        "             psub-cpu-factorized (1 thread and all) against osd-cpu and osd-omp (1 and all\n"
        "             threads; factorized and cascading tables), OpenSubdiv in the faster of its 3- and\n"
        "             4-float layouts; speed-ups are against its fastest configuration in the same run\n"
        "  bandwidth  STREAM-style triad (1 thread, all threads), each evaluator's bytes per frame and\n"
        "             its fraction of the triad\n"
        "  shape      face counts per step of both schemes (the paper's Table I), volume and bounding-box\n"
        "             diagonal of both refined meshes\n"
        "Markdown on stdout, progress on stderr. Timings are never part of the tests.\n"
        "Examples:\n"
        "  psub bench --json bench.json --plot bench.svg     # defaults: a few minutes\n"
        "  psub bench /path/to/stanford-bunny.obj data/spot_control_mesh.obj --json bunny.json\n"
        "  psub bench --quick                                # smallest size of each model");

    PlayOptions playOptions;
    CLI::App* pl = addPlayCommand(app, playOptions);

#if PSUB_HAVE_RENDER
    RenderCommandOptions renderOptions;
    CLI::App* re = addRenderCommand(app, renderOptions);
    Figure5Options figure5Options;
    CLI::App* fi = addFigure5Command(app, figure5Options);
    Figure5Options figureShapeOptions;
    CLI::App* fs = addFigureShapeCommand(app, figureShapeOptions);
#endif
#if PSUB_HAVE_VIEW
    ViewOptions viewOptions;
    CLI::App* vi = addViewCommand(app, viewOptions);
#endif

    if (argc > 1 && argv[1][0] != '-') {
        const std::string message = unknownCommandMessage(app, argv[1]);
        if (!message.empty()) {
            std::fprintf(stderr, "%s\n", message.c_str());
            return 2;
        }
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::Success& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {  // one line, naming the option
        std::string message = e.what();
        std::replace(message.begin(), message.end(), '\n', ' ');
        std::fprintf(stderr, "psub: usage error: %s (see psub COMMAND --help)\n", message.c_str());
        return 2;
    }
    if (sub->parsed() && (sub->count("--at") || sub->count("--anim")) && !isGltfPath(subdivide.input)) {
        std::fprintf(stderr, "psub subdivide: --at and --anim apply to glTF input (.gltf, .glb) only\n");
        return 2;
    }
    if (sub->parsed() && sub->count("--anim") && !sub->count("--at")) {
        std::fprintf(stderr, "psub subdivide: --anim needs --at SECONDS\n");
        return 2;
    }
    if (sub->parsed() && sub->count("--at")) subdivide.at = subdivideAt;
    if (sub->parsed() && subdivide.scheme == Scheme::CatmullClark && sub->count("--preprocess")) {
        std::fprintf(stderr, "psub subdivide: --preprocess applies to --scheme ps only\n");
        return 2;
    }
    if (sub->parsed() && subdivide.scheme == Scheme::CatmullClark && sub->count("--rules")) {
        std::fprintf(stderr, "psub subdivide: --rules applies to --scheme ps only\n");
        return 2;
    }
    if (sub->parsed() && subdivide.scheme == Scheme::CatmullClark && sub->count("--boundary")) {
        std::fprintf(stderr, "psub subdivide: --boundary applies to --scheme ps only (Catmull-Clark's is smooth)\n");
        return 2;
    }
    if (sub->parsed() && subdivide.scheme == Scheme::CatmullClark && sub->count("--uv-linear")) {
        std::fprintf(stderr, "psub subdivide: --uv-linear applies to --scheme ps only\n");
        return 2;
    }
    if (sub->parsed() && subdivide.scheme == Scheme::CatmullClark && sub->count("--backend")) {
        std::fprintf(stderr, "psub subdivide: --backend applies to --scheme ps only\n");
        return 2;
    }

    const auto runCommand = [&]() -> int {
        if (sub->parsed()) return runSubdivide(subdivide);
        if (st->parsed()) return runStats(stats);
        if (de->parsed()) return runDemo(demo);
        if (an->parsed()) return runAnalyze(analyze);
        if (co->parsed()) return runCompare(compare);
        if (pl->parsed()) return runPlay(playOptions);
#if PSUB_HAVE_RENDER
        if (re->parsed() && renderOptions.scheme == Scheme::CatmullClark && re->count("--rules")) {
            std::fprintf(stderr, "psub render: --rules applies to --scheme ps only\n");
            return 2;
        }
        if (re->parsed()) return runRender(renderOptions);
        if (fi->parsed()) return runFigure5(figure5Options);
        if (fs->parsed()) return runFigureShape(figureShapeOptions);
#endif
#if PSUB_HAVE_VIEW
        if (vi->parsed()) return runView(viewOptions);
#endif
        if (be->parsed()) {
            // The outputs are checked now, not after a run of minutes.
            if (!benchOptions.jsonPath.empty()) checkOutput(benchOptions.jsonPath);
            if (!benchOptions.plotPath.empty()) checkOutput(benchOptions.plotPath);
            benchOptions.dataDir = dataDir();
            for (int i = 0; i < argc; ++i) {
                const std::string arg = argv[i];
                benchOptions.command += (i ? " " : "") +
                                        (arg.find(' ') == std::string::npos ? arg : "'" + arg + "'");
            }
            return bench::runBench(benchOptions);
        }
        return 2;
    };

    try {
        return runAndFinish([&] { return runCommand(); });
    } catch (const InputError& e) {
        std::fprintf(stderr, "psub: error: %s\n", e.what());
        return 1;
    } catch (const OutputError& e) {
        std::fprintf(stderr, "psub: error: %s\n", e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "psub: error: out of memory\n");
        return 1;
    } catch (const std::exception& e) {  // a last resort: every known failure has its own message
        std::fprintf(stderr, "psub: error: %s\n", e.what());
        return 1;
    }
}

