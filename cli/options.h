// Option helpers shared by the psub commands (CLI11): choices among named values, and every
// numeric option (integers, reals, byte counts, WIDTHxHEIGHT sizes) parsed by the one policy of
// numbers.h, so a bad value is a usage error naming the option; the names of the engine's choices.
#pragma once

#include "commands.h"
#include "numbers.h"

#include <CLI/CLI.hpp>

#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace psub::cli {

inline const std::map<std::string, Scheme> kSchemeNames = {{"ps", Scheme::PS}, {"cc", Scheme::CatmullClark}};
inline const std::map<std::string, Rules> kRulesNames = {{"paper", Rules::Paper}, {"robust", Rules::Robust}, {"shape", Rules::Shape}};
inline const std::map<std::string, Boundary> kBoundaryNames = {{"paper", Boundary::Paper}, {"smooth", Boundary::Smooth}};
inline const std::map<std::string, UvLinear> kUvLinearNames = {{"boundaries", UvLinear::Boundaries}, {"all", UvLinear::All}};
// Where the stencils run, for commands that need a definite answer (no "auto").
inline const std::map<std::string, Backend> kCpuOrVulkan = {{"cpu", Backend::Cpu}, {"vulkan", Backend::Vulkan}};

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

// A validator running one of numbers.h's parsers on the option's text.
template <class Parse>
CLI::Validator numberCheck(Parse parse, const std::string& description) {
    return CLI::Validator([parse](std::string& value) { return parse(value); }, description);
}

// An integer option in least..most; `target` starts at `initial`.
template <class Int>
CLI::Option* addInteger(CLI::App* command, const std::string& name, Int& target, long long least, long long most,
                        const std::string& help, Int initial) {
    target = initial;
    return command
        ->add_option_function<std::string>(
            name,
            [&target](const std::string& value) {
                long long parsed = 0;
                parseInteger(value, LLONG_MIN, LLONG_MAX, parsed);
                target = Int(parsed);
            },
            help)
        ->check(numberCheck(
            [least, most](const std::string& value) {
                long long parsed = 0;
                return parseInteger(value, least, most, parsed);
            },
            rangeText(least, most)))
        ->type_name("INT")
        ->default_str(std::to_string(initial));
}

// A finite real option in least..most; `target` starts at `initial`.
inline CLI::Option* addReal(CLI::App* command, const std::string& name, double& target, double least, double most,
                            const std::string& help, double initial) {
    target = initial;
    return command
        ->add_option_function<std::string>(
            name,
            [&target](const std::string& value) { parseReal(value, -HUGE_VAL, HUGE_VAL, target); }, help)
        ->check(numberCheck(
            [least, most](const std::string& value) {
                double parsed = 0;
                return parseReal(value, least, most, parsed);
            },
            realText(least) + ".." + realText(most)))
        ->type_name("NUMBER")
        ->default_str(realText(initial));
}

// A byte count (512M, 3G, ...); `target` keeps its value when the option is absent.
inline CLI::Option* addBytes(CLI::App* command, const std::string& name, std::uint64_t& target,
                             const std::string& help) {
    return command
        ->add_option_function<std::string>(
            name, [&target](const std::string& value) { parseBytes(value, target); }, help)
        ->check(numberCheck(
            [](const std::string& value) {
                std::uint64_t parsed = 0;
                return parseBytes(value, parsed);
            },
            ""))
        ->type_name("BYTES");
}

// WIDTHxHEIGHT, each in least..16384, into width and height.
inline CLI::Option* addSize(CLI::App* command, const std::string& name, std::uint32_t& width,
                            std::uint32_t& height, const std::string& help, unsigned least,
                            const std::string& defaultText) {
    return command
        ->add_option_function<std::string>(
            name,
            [&width, &height, least](const std::string& value) { parseSize(value, least, 16384, width, height); },
            help)
        ->check(numberCheck(
            [least](const std::string& value) {
                std::uint32_t w = 0, h = 0;
                return parseSize(value, least, 16384, w, h);
            },
            ""))
        ->type_name("WxH")
        ->default_str(defaultText);
}

// --msaa: samples per pixel of the offscreen pictures (lowered to what the device supports).
inline CLI::Option* addSamples(CLI::App* command, std::uint32_t& samples) {
    return addInteger(command, "--msaa", samples, 1, 8,
                      "samples per pixel, 1, 2, 4 or 8 (lowered to what the device has; 1 is about 4x "
                      "faster on lavapipe)",
                      std::uint32_t(4))
        ->check(numberCheck(
            [](const std::string& value) {
                long long parsed = 0;
                return parseInteger(value, 1, 8, parsed).empty() && (parsed & (parsed - 1)) == 0
                           ? std::string()
                           : std::string("expected 1, 2, 4 or 8");
            },
            ""));
}

}  // namespace psub::cli
