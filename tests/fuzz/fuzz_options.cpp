// libFuzzer target: the CLI's option parsing. The input is split at newlines into an argument
// list for a command with one option of each numeric kind (integer, real, byte count, size,
// MSAA samples; the helpers of cli/options.h, the one policy of cli/numbers.h). Whatever the
// arguments, parsing must end in a value inside its option's range or a CLI11 ParseError:
// never a crash, a wrapped or non-finite value, or another exception.
#include "options.h"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace {

struct Parsed {
    int levels = 0;
    std::uint64_t extendBelow = 0, memory = 7;
    double fps = 0;
    std::uint32_t width = 1280, height = 720, samples = 0;  // addSize keeps these when absent
};

void check(bool holds) {
    if (!holds) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::vector<std::string> args{"psub"};
    std::string current;
    for (std::size_t i = 0; i < size && args.size() < 64; ++i) {
        if (data[i] == '\n') {
            args.push_back(current), current.clear();
        } else {
            current += char(data[i]);
        }
    }
    args.push_back(current);
    std::vector<char*> argv;
    for (std::string& arg : args) argv.push_back(arg.data());

    Parsed p;
    CLI::App app{"fuzz"};
    psub::cli::addInteger(app.add_subcommand("x", "")->fallthrough(), "-l,--levels", p.levels, 0, 30, "", 3);
    psub::cli::addInteger(&app, "--extend-below", p.extendBelow, 0, 4294967295LL, "", std::uint64_t(5));
    psub::cli::addReal(&app, "--anim-fps", p.fps, 1, 10000, "", 30);
    psub::cli::addBytes(&app, "--max-memory", p.memory, "");
    psub::cli::addSize(&app, "--size", p.width, p.height, "", 1, "1280x720");
    psub::cli::addSamples(&app, p.samples);
    try {
        app.parse(int(argv.size()), argv.data());
    } catch (const CLI::ParseError&) {
        return 0;
    }
    check(p.levels >= 0 && p.levels <= 30);
    check(p.extendBelow <= 4294967295ULL);
    check(std::isfinite(p.fps) && p.fps >= 1 && p.fps <= 10000);
    check(p.memory > 0);
    check(p.width >= 1 && p.width <= 16384 && p.height >= 1 && p.height <= 16384);
    check(p.samples == 1 || p.samples == 2 || p.samples == 4 || p.samples == 8);
    return 0;
}
