// Option helpers shared by the psub commands (CLI11): choices among named values, image sizes
// written WIDTHxHEIGHT, and the names of the engine's choices.
#pragma once

#include "commands.h"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace psub::cli {

inline const std::map<std::string, Scheme> kSchemeNames = {{"ps", Scheme::PS}, {"cc", Scheme::CatmullClark}};
inline const std::map<std::string, Rules> kRulesNames = {{"paper", Rules::Paper}, {"robust", Rules::Robust}, {"shape", Rules::Shape}};
inline const std::map<std::string, Boundary> kBoundaryNames = {{"paper", Boundary::Paper}, {"smooth", Boundary::Smooth}};
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

// WIDTHxHEIGHT, each in least..16384, into width and height.
inline CLI::Option* addSize(CLI::App* command, const std::string& name, std::uint32_t& width,
                            std::uint32_t& height, const std::string& help, unsigned least,
                            const std::string& defaultText) {
    const auto parse = [](const std::string& value, unsigned& w, unsigned& h) {
        char x = 0, extra = 0;
        return std::sscanf(value.c_str(), "%u%c%u%c", &w, &x, &h, &extra) == 3 && x == 'x';
    };
    return command
        ->add_option_function<std::string>(
            name,
            [&width, &height, parse](const std::string& value) {
                unsigned w = 0, h = 0;
                parse(value, w, h);
                width = w, height = h;
            },
            help)
        ->check(CLI::Validator(
            [least, parse](std::string& value) {
                unsigned w = 0, h = 0;
                return parse(value, w, h) && w >= least && h >= least && w <= 16384 && h <= 16384
                           ? std::string()
                           : "expected WIDTHxHEIGHT, each " + std::to_string(least) + "..16384 (e.g. 1280x720)";
            },
            ""))
        ->type_name("WxH")
        ->default_str(defaultText);
}

// --msaa: samples per pixel of the offscreen pictures (lowered to what the device supports).
inline CLI::Option* addSamples(CLI::App* command, std::uint32_t& samples) {
    return command
        ->add_option("--msaa", samples,
                     "samples per pixel, 1, 2, 4 or 8 (lowered to what the device has; 1 is about 4x "
                     "faster on lavapipe)")
        ->check(CLI::IsMember({1u, 2u, 4u, 8u}))
        ->default_val(4);
}

}  // namespace psub::cli
