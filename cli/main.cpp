// psub: the command-line program. Parses arguments (CLI11) and maps outcomes to exit codes:
// 0 success, 1 bad input (one line on stderr), 2 usage error.
#include "commands.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <map>

namespace {

using namespace psub;
using namespace psub::cli;

const std::map<std::string, Preprocess> kPreprocess = {
    {"auto", Preprocess::Auto}, {"always", Preprocess::Always}, {"never", Preprocess::Never}};
const std::map<std::string, Scheme> kScheme = {{"ps", Scheme::PS}, {"cc", Scheme::CatmullClark}};

// Levels are capped so closed-form counts stay in 64 bits; the memory guard stops far sooner.
constexpr int kMaxLevels = 30;

// A choice among named values: shown by name in --help, stored as the enum.
template <class Enum>
CLI::Option* addChoice(CLI::App* command, const std::string& name, Enum& target,
                       const std::map<std::string, Enum>& choices, const std::string& help,
                       const std::string& defaultName) {
    std::vector<std::string> names;
    for (const auto& entry : choices) names.push_back(entry.first);
    return command
        ->add_option_function<std::string>(
            name, [&target, &choices](const std::string& value) { target = choices.at(value); }, help)
        ->check(CLI::IsMember(names))
        ->type_name("TEXT")
        ->default_str(defaultName);
}

void addPreprocess(CLI::App* command, Preprocess& target) {
    addChoice(command, "--preprocess", target, kPreprocess,
              "auto: apply the paired method when a face is not a quad (triangles on the "
              "boundary are legal P-S input); always; never (error if it is needed)",
              "auto");
}

void addMaxMemory(CLI::App* command, std::uint64_t& target) {
    command->add_option("--max-memory", target,
                        "refuse work estimated to need more bytes than this (suffixes K M G; "
                        "default 3/4 of physical memory)")
        ->transform(CLI::AsSizeValue(false));
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"psub: P-S (Liu-Yang-Guan) subdivision surfaces, with OpenSubdiv's "
                 "Catmull-Clark beside them for comparison."};
    app.require_subcommand(1);
    app.footer("Run 'psub COMMAND --help' for a command's options and an example.\n"
               "Exit status: 0 success, 1 bad input, 2 usage error.");

    SubdivideOptions subdivide;
    CLI::App* sub = app.add_subcommand("subdivide", "Refine a mesh and write it as OBJ");
    sub->add_option("input", subdivide.input, "input mesh (.obj)")->required();
    sub->add_option("-o,--output", subdivide.output, "output mesh (.obj), written atomically")->required();
    sub->add_option("-l,--levels", subdivide.levels,
                    "refinement steps (P-S steps after any preprocessing; 0 writes the "
                    "preprocessed mesh)")
        ->check(CLI::Range(0, kMaxLevels))->default_val(1);
    addChoice(sub, "--scheme", subdivide.scheme, kScheme,
              "ps: P-S; cc: Catmull-Clark through OpenSubdiv (edge-only boundary, no creases)", "ps");
    addPreprocess(sub, subdivide.preprocess);
    addMaxMemory(sub, subdivide.maxMemory);
    sub->footer("Example:\n  psub subdivide data/cow.obj -o cow_ps4.obj --levels 4\n"
                "  psub subdivide data/cow.obj -o cow_cc2.obj --levels 2 --scheme cc\n"
                "Vertex order (SPEC.md): children of old vertices first, then one vertex per "
                "old face.");

    StatsOptions stats;
    CLI::App* st = app.add_subcommand("stats", "Count vertices, edges, faces per level, P-S beside Catmull-Clark");
    st->add_option("input", stats.input, "input mesh (.obj)")->required();
    st->add_option("-l,--levels", stats.levels, "P-S steps to count")
        ->check(CLI::Range(0, kMaxLevels))->default_val(4);
    addPreprocess(st, stats.preprocess);
    addMaxMemory(st, stats.maxMemory);
    st->footer("Example:\n  psub stats data/cube.obj --levels 6");

    DemoOptions demo;
    CLI::App* de = app.add_subcommand("demo", "A first look: the bundled cow under P-S and Catmull-Clark");
    de->add_option("--model", demo.model, "another mesh instead of the bundled cow");
    de->add_option("-l,--levels", demo.levels, "P-S steps (Catmull-Clark gets half as many)")
        ->check(CLI::Range(1, 8))->default_val(4);
    de->add_option("-o,--output-dir", demo.outputDir, "also write the refined meshes here")
        ->check(CLI::ExistingDirectory);
    de->footer("Example:\n  psub demo\n  psub demo --output-dir /tmp --levels 2");

    try {
        app.parse(argc, argv);
    } catch (const CLI::Success& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        return 2;
    }
    if (sub->parsed() && subdivide.scheme == Scheme::CatmullClark && sub->count("--preprocess")) {
        std::fprintf(stderr, "psub subdivide: --preprocess applies to --scheme ps only\n");
        return 2;
    }

    try {
        if (sub->parsed()) return runSubdivide(subdivide);
        if (st->parsed()) return runStats(stats);
        if (de->parsed()) return runDemo(demo);
    } catch (const InputError& e) {
        std::fprintf(stderr, "psub: error: %s\n", e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "psub: error: out of memory\n");
        return 1;
    }
    return 2;
}
