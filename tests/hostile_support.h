// Helpers of the hostile-input tests (test_hostile_*.cpp): a temporary directory per test,
// files written into it, and the real psub run on them under a timeout (so that a hang fails
// rather than hangs), with the contract of README "Bad input" checked in one place.
#pragma once

#include "test_support.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace psub::test {

namespace fs = std::filesystem;

inline std::string readFile(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

// One OBJ "v" line per vertex of the unit cube scaled by `scale`, then its six quads.
inline std::string cubeObj(const std::string& scale) {
    std::ostringstream out;
    for (int v = 0; v < 8; ++v)
        out << "v " << ((v & 1) ? "" : "-") << scale << ' ' << ((v & 2) ? "" : "-") << scale << ' '
            << ((v & 4) ? "" : "-") << scale << '\n';
    out << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 2 4 8 6\nf 4 3 7 8\nf 3 1 5 7\n";
    return out.str();
}

// A tetrahedron's buffer: 4 float VEC3 positions (48 bytes), then 12 uint16 indices (24 bytes).
inline std::string tetBin() {
    const float positions[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const std::uint16_t indices[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    std::string bytes(72, '\0');
    std::memcpy(bytes.data(), positions, 48);
    std::memcpy(bytes.data() + 48, indices, 24);
    return bytes;
}

// The tetrahedron as glTF 2.0 JSON over buffer 0 (72 bytes; `buffer` is its JSON object body,
// e.g. "\"uri\": \"tet.bin\", "). The other arguments go in verbatim.
inline std::string tetGltf(const std::string& buffer, const std::string& accessorOffset = "0",
                           const std::string& viewOffset = "0", const std::string& scene = "0",
                           const std::string& more = "") {
    return "{\"asset\": {\"version\": \"2.0\"}, \"scene\": " + scene +
           ", \"scenes\": [{\"nodes\": [0]}], \"nodes\": [{\"mesh\": 0}],\n"
           "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1}]}],\n"
           "\"accessors\": [{\"bufferView\": 0, \"byteOffset\": " + accessorOffset +
           ", \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\", \"min\": [0, 0, 0], \"max\": [1, 1, 1]},\n"
           " {\"bufferView\": 1, \"componentType\": 5123, \"count\": 12, \"type\": \"SCALAR\"}],\n"
           "\"bufferViews\": [{\"buffer\": 0, \"byteOffset\": " + viewOffset + ", \"byteLength\": 48},"
           " {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 24}],\n"
           "\"buffers\": [{" + buffer + "\"byteLength\": 72}]" + more + "}\n";
}

// A .glb of `json` and `bin` chunks with header version `version`.
inline std::string glb(std::string json, const std::string& bin, std::uint32_t version = 2) {
    while (json.size() % 4) json += ' ';
    const auto word = [](std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
    const std::uint32_t total = std::uint32_t(12 + 8 + json.size() + 8 + bin.size());
    return "glTF" + word(version) + word(total) + word(std::uint32_t(json.size())) + "JSON" + json +
           word(std::uint32_t(bin.size())) + std::string("BIN\0", 4) + bin;
}

class HostileTest : public ::testing::Test {
protected:
    struct Run {
        int status = -1;  // exit status; 124: timed out; 128 + N: killed by signal N
        std::string out, err;
    };

    void SetUp() override {
        std::string pattern = (fs::path(testing::TempDir()) / "psub-hostile-XXXXXX").string();
        ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
        root_ = pattern;
        work_ = root_ / "work";
        fs::create_directory(work_);
    }
    void TearDown() override {
        std::error_code ignored;
        fs::remove_all(root_, ignored);
    }

    // Writes `content` to work/NAME; returns its path.
    std::string write(const std::string& name, const std::string& content) {
        std::ofstream(work_ / name, std::ios::binary) << content;
        return path(name);
    }
    std::string path(const std::string& name) const { return (work_ / name).string(); }

    // Every file under work/ with its contents.
    std::map<std::string, std::string> snapshot() const {
        std::map<std::string, std::string> files;
        for (const auto& entry : fs::recursive_directory_iterator(work_)) {
            const fs::path p = entry.path();
            files[p.string()] = entry.is_regular_file() ? readFile(p) : std::string("(not a file)");
        }
        return files;
    }

    // psub ARGS (shell words) run in work/, killed after `seconds`.
    Run psub(const std::string& args, int seconds = 120) {
        const fs::path out = root_ / "stdout.txt", err = root_ / "stderr.txt";
        const std::string command = "cd '" + work_.string() + "' && ASAN_OPTIONS=detect_leaks=0 timeout -k 5 " +
                                    std::to_string(seconds) + " '" PSUB_EXE "' " + args + " >'" + out.string() +
                                    "' 2>'" + err.string() + "' </dev/null";
        const int raw = std::system(command.c_str());
        Run run;
        EXPECT_TRUE(raw != -1 && WIFEXITED(raw)) << command;
        if (raw != -1 && WIFEXITED(raw)) run.status = WEXITSTATUS(raw);
        run.out = readFile(out);
        run.err = readFile(err);
        return run;
    }

    // The contract for refused input: exit `status`, stderr one line "psub: error: ..." that
    // contains every needle, nothing on stdout, no file added under work/, none changed.
    Run refused(const std::string& args, int status, std::initializer_list<std::string> needles, int seconds = 120) {
        const auto before = snapshot();
        const Run run = psub(args, seconds);
        EXPECT_EQ(run.status, status) << "psub " << args << "\n" << run.err;
        EXPECT_EQ(run.err.rfind("psub: error: ", 0), 0u) << run.err;
        EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
        for (const std::string& needle : needles) EXPECT_TRUE(contains(run.err, needle)) << needle << " not in: " << run.err;
        EXPECT_EQ(run.out, "") << "stdout: " << run.out;
        EXPECT_EQ(snapshot(), before) << "psub " << args << " added or changed a file";
        return run;
    }

    fs::path root_, work_;
};

}  // namespace psub::test
