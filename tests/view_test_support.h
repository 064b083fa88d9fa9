// What the tests of `psub view` as a program share: running it under a fresh Xvfb server with
// the validation layer on, the one check that a window can open here (a failure without one; a
// skip only with PSUB_ALLOW_NO_VULKAN=1), scripts and logs in the test temp dir, and the
// screenshot tolerance. For tests/test_view.cpp and tests/test_view_frames.cpp.
#pragma once

#include "psub/image.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace psub::test {

// A file name in the test temp dir, unique to this process.
inline std::string viewTemp(const std::string& name) {
    return testing::TempDir() + "/psub-view-" + std::to_string(::getpid()) + "-" + name;
}

// The prefix that runs psub under a fresh Xvfb server (`xvfb-run -a`, a 1600 x 1200 screen). The
// sanitizer stage preloads lavapipe into every process (scripts/setup.sh); xvfb-run is a shell
// script that starts several programs, each of which would load it (1.1 s a start against 0.2 s
// here), so the preload is taken off for xvfb-run and put back for psub alone.
inline std::string underXvfb() {
    const char* preload = std::getenv("LD_PRELOAD");
    const std::string xvfb = "xvfb-run -a -s '-screen 0 1600x1200x24'";
    if (preload == nullptr || *preload == '\0') return xvfb;
    return "env -u LD_PRELOAD " + xvfb + " env LD_PRELOAD=" + test::quoted(preload);
}

// `prefix psub args` with the validation layer on and `environment` (VAR=value words) too;
// stdout and stderr captured.
inline PsubRun runValidated(const std::string& prefix, const std::string& args, const std::string& environment = "") {
    PsubHow how;
    how.environment = std::string(kNoLeakCheck) + " PSUB_VULKAN_VALIDATION=1 " + environment;
    how.prefix = prefix;
    return runPsub(args, how);
}

// `psub view ARGS` under a fresh Xvfb server.
inline PsubRun view(const std::string& args, const std::string& environment = "") {
    return runValidated(underXvfb(), "view " + args, environment);
}

// Why psub view cannot run here (asked once): empty when it can.
inline const std::string& windowProblem() {
    static const std::string problem = [] {
        if (std::system("command -v xvfb-run >/dev/null 2>&1") != 0) return std::string("xvfb-run is not installed");
        const PsubRun r = view(test::quoted(dataPath("cube.obj")) + " --levels 1 --frames 1");
        return r.status == 0 ? std::string() : "psub view failed: " + r.err;
    }();
    return problem;
}

// The fixture of every window test: it fails without a window (skips with PSUB_ALLOW_NO_VULKAN=1).
class WindowTest : public ::testing::Test {
protected:
    void SetUp() override {
        if (windowProblem().empty()) return;
        if (noVulkanAllowed()) GTEST_SKIP() << "no window (allowed by PSUB_ALLOW_NO_VULKAN=1): " << windowProblem();
        FAIL() << "no window: " << windowProblem() << " (set PSUB_ALLOW_NO_VULKAN=1 to skip)";
    }
};

// Exit status 0 and no validation message.
inline void expectClean(const PsubRun& r) {
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(contains(r.err, "alidation")) << r.err;
}

// A script file (`psub view --script`) holding `text`.
inline std::string viewScript(const std::string& name, const std::string& text) {
    const std::string path = viewTemp(name);
    std::ofstream(path) << text;
    return path;
}

// The number after "key": in one JSON line (the log's fields are flat or in "stages").
inline double logField(const std::string& line, const std::string& key) {
    const std::size_t at = line.find("\"" + key + "\": ");
    if (at == std::string::npos) {
        ADD_FAILURE() << "no " << key << " in " << line;
        return -1;
    }
    return std::strtod(line.c_str() + at + key.size() + 4, nullptr);
}

inline std::vector<std::string> logLines(const std::string& path) {
    std::ifstream in(path);
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
}

// The screenshot tolerance of psub view's tests: mean absolute difference <= 2/255 per channel,
// at most 1% of pixels off by more than 16/255 in some channel; `why` says by how much.
inline bool closeEnough(const Image& a, const Image& b, std::string& why) {
    if (a.width != b.width || a.height != b.height || a.rgba.size() != b.rgba.size()) {
        why = "sizes differ";
        return false;
    }
    double sum[3] = {0, 0, 0};
    std::size_t off = 0;
    for (std::size_t i = 0; i < a.rgba.size(); i += 4) {
        bool far = false;
        for (std::size_t c = 0; c < 3; ++c) {
            const int d = std::abs(int(a.rgba[i + c]) - int(b.rgba[i + c]));
            sum[c] += d;
            far = far || d > 16;
        }
        off += far;
    }
    const double pixels = double(a.width) * a.height;
    why = "mean differences " + std::to_string(sum[0] / pixels) + ", " + std::to_string(sum[1] / pixels) + ", " +
          std::to_string(sum[2] / pixels) + "; " + std::to_string(off) + " pixels far off";
    return sum[0] / pixels <= 2 && sum[1] / pixels <= 2 && sum[2] / pixels <= 2 && double(off) <= 0.01 * pixels;
}

}  // namespace psub::test
