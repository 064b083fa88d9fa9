// The one parsing policy for numeric option values (psub's integers, reals, byte counts and
// WIDTHxHEIGHT sizes): decimal only, so "010" is ten, never octal; no trailing text; a value
// that overflows or lies outside the option's range is refused, never wrapped or clamped;
// reals must be finite (no nan, inf). Each parser returns "" on success, else the reason.
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>

namespace psub::cli {

// "least..most", for messages.
inline std::string rangeText(long long least, long long most) {
    return std::to_string(least) + ".." + std::to_string(most);
}

// The shortest text that reads back as `value`.
inline std::string realText(double value) {
    char text[32];
    return std::string(text, std::to_chars(text, text + sizeof text, value).ptr);
}

// A decimal integer in [least, most]: an optional sign, then digits (leading zeros allowed).
inline std::string parseInteger(std::string_view text, long long least, long long most, long long& value) {
    const std::string expected = "expected a whole number in " + rangeText(least, most);
    if (!text.empty() && text[0] == '+') text.remove_prefix(1);
    if (text.empty() || text[0] == '+') return expected + ", got nothing";
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value, 10);
    if (error == std::errc::result_out_of_range) return expected + " (this one overflows)";
    if (error != std::errc() || end != text.data() + text.size()) return expected;
    if (value < least || value > most) return expected;
    return {};
}

// A finite decimal real in [least, most] ("1e3" and "0.5" are fine; nan, inf and hex are not).
inline std::string parseReal(std::string_view text, double least, double most, double& value) {
    const std::string expected = "expected a finite number from " + realText(least) + " to " + realText(most);
    if (!text.empty() && text[0] == '+') text.remove_prefix(1);
    if (text.empty() || text[0] == '+') return expected;
    const auto [end, error] =
        std::from_chars(text.data(), text.data() + text.size(), value, std::chars_format::general);
    if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) return expected;
    if (value < least || value > most) return expected;
    return {};
}

// A positive byte count: digits, then an optional K, M, G or T (powers of 1024, either case),
// then an optional B or iB: "512M", "3GiB", "1000000". Overflow of 64 bits is refused.
inline std::string parseBytes(std::string_view text, std::uint64_t& value) {
    const std::string expected = "expected a positive number of bytes, e.g. 512M or 3G (K M G T: powers of 1024)";
    std::size_t digits = 0;
    while (digits < text.size() && text[digits] >= '0' && text[digits] <= '9') ++digits;
    if (digits == 0) return expected;
    const auto [end, error] = std::from_chars(text.data(), text.data() + digits, value, 10);
    if (error == std::errc::result_out_of_range) return expected + " (this one overflows)";
    if (error != std::errc() || end != text.data() + digits) return expected;
    std::string_view unit = text.substr(digits);
    int shift = 0;
    if (!unit.empty()) {
        const std::string_view prefixes = "KMGT", lower = "kmgt";
        const std::size_t k = std::min(prefixes.find(unit[0]), lower.find(unit[0]));
        if (k != std::string_view::npos) shift = 10 * int(k + 1), unit.remove_prefix(1);
        if (unit == "iB" && shift > 0) unit = {};
        if (unit == "B" || unit == "b") unit = {};
    }
    if (!unit.empty()) return expected;
    if (value == 0) return expected;
    if (shift > 0 && value > (UINT64_MAX >> shift)) return expected + " (this one overflows)";
    value <<= shift;
    return {};
}

// WIDTHxHEIGHT, each a decimal integer in [least, most].
inline std::string parseSize(std::string_view text, unsigned least, unsigned most, std::uint32_t& width,
                             std::uint32_t& height) {
    const std::string expected = "expected WIDTHxHEIGHT, each " + rangeText(least, most) + " (e.g. 1280x720)";
    const std::size_t x = text.find('x');
    if (x == std::string_view::npos) return expected;
    long long w = 0, h = 0;
    if (!parseInteger(text.substr(0, x), least, most, w).empty() ||
        !parseInteger(text.substr(x + 1), least, most, h).empty() || text[0] == '+' || text[x + 1] == '+')
        return expected;
    width = std::uint32_t(w), height = std::uint32_t(h);
    return {};
}

}  // namespace psub::cli
