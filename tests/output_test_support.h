// Helpers of the output and option tests (test_output, test_hostile_output,
// test_hostile_options): running the real psub binary with its streams captured, temporary
// directories, and listing what a directory holds afterwards.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

namespace psub::test {

namespace fs = std::filesystem;

inline std::string readFile(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline void writeFile(const fs::path& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

// Sorted names in `dir` (hidden ones too, so a left-over temporary shows).
inline std::vector<std::string> namesIn(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

inline bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

inline long countOf(const std::string& text, const std::string& part) {
    long count = 0;
    for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++count;
    return count;
}

inline std::vector<std::string> linesOf(const std::string& text) {
    std::vector<std::string> lines;
    std::size_t start = 0;
    while (start < text.size()) {
        const std::size_t end = text.find('\n', start);
        lines.push_back(text.substr(start, end - start));
        if (end == std::string::npos) break;
        start = end + 1;
    }
    return lines;
}

// A fresh directory, removed with everything in it at the end of the test.
class ScratchDir {
public:
    ScratchDir() {
        std::string pattern = (fs::temp_directory_path() / "psub-hostile-XXXXXX").string();
        path_ = ::mkdtemp(pattern.data()) ? fs::path(pattern) : fs::path();
    }
    ~ScratchDir() {
        std::error_code ignored;
        fs::remove_all(path_, ignored);
    }
    ScratchDir(const ScratchDir&) = delete;
    ScratchDir& operator=(const ScratchDir&) = delete;
    const fs::path& path() const { return path_; }
    fs::path operator/(const std::string& name) const { return path_ / name; }

private:
    fs::path path_;
};

struct PsubRun {
    int status = -1;
    std::string out, err;
};

// Runs `psub ARGS` through the shell. `stdoutTo` replaces the capture of standard output
// (e.g. "/dev/full"); the captures live in `scratch`. Leak detection is off in sanitizer builds:
// the Vulkan driver (lavapipe) keeps a few allocations until exit.
inline PsubRun runPsub(const ScratchDir& scratch, const std::string& args, const std::string& stdoutTo = "") {
    const fs::path out = scratch / ".stdout", err = scratch / ".stderr";
    const std::string command = "ASAN_OPTIONS=detect_leaks=0 '" PSUB_EXE "' " + args + " >'" + (stdoutTo.empty() ? out.string() : stdoutTo) +
                                "' 2>'" + err.string() + "' </dev/null";
    const int raw = std::system(command.c_str());
    PsubRun run;
    EXPECT_TRUE(raw != -1 && WIFEXITED(raw)) << command << " (killed by a signal?)";
    if (raw != -1 && WIFEXITED(raw)) run.status = WEXITSTATUS(raw);
    run.out = stdoutTo.empty() ? readFile(out) : "";
    run.err = readFile(err);
    std::error_code ignored;
    fs::remove(out, ignored);
    fs::remove(err, ignored);
    return run;
}

// The one stderr line of a failed run; a test failure when there are more or none.
inline std::string oneLine(const PsubRun& run) {
    const std::vector<std::string> lines = linesOf(run.err);
    EXPECT_EQ(lines.size(), 1u) << run.err;
    return lines.empty() ? std::string() : lines.front();
}

// `path` in single quotes for the shell (built by append: GCC 12's -Wrestrict misfires on a + chain).
inline std::string quoted(const fs::path& path) {
    std::string text = "'";
    text += path.string();
    text += '\'';
    return text;
}

}  // namespace psub::test
