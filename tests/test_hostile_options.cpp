// Hostile inputs, class 5 (option values that slip through) and class 7's unknown command:
// every numeric option of every psub command, given negative, overflowing, non-finite,
// octal-looking, trailing-junk and out-of-range values, is a usage error (exit 2) on one
// line naming the option, and nothing is written; decimal values with leading zeros mean
// what they say.
#include "test_support.h"

#include "numbers.h"

#include <gtest/gtest.h>

namespace psub {
namespace {

using namespace psub::test;

const std::string kCube = std::string(PSUB_DATA) + "/cube.obj";

class HostileOptions : public ::testing::Test {
protected:
    void SetUp() override {
        ASSERT_FALSE(scratch_.path().empty());
        fs::create_directory(out());
    }
    fs::path out() const { return scratch_ / "out"; }
    PsubRun psub(const std::string& args) { return runPsub(scratch_, args); }

    // `command` with `option value` appended: exit 2, one line naming the option, no file.
    void expectUsageError(const std::string& command, const std::string& option, const std::string& value) {
        SCOPED_TRACE(command + " " + option + " '" + value + "'");
        const PsubRun r = psub(command + " " + option + " '" + value + "'");
        EXPECT_EQ(r.status, 2);
        const std::string line = oneLine(r);
        EXPECT_EQ(line.rfind("psub: usage error: ", 0), 0u) << line;
        EXPECT_TRUE(contains(line, option)) << line;
        EXPECT_TRUE(r.out.empty()) << r.out.substr(0, 200);
        EXPECT_TRUE(namesIn(out()).empty());
    }

    ScratchDir scratch_;
};

// Values no integer option takes. 4294967297 = 2^32 + 1 (1 if wrapped to 32 bits); the
// 23-digit one overflows even 64 bits.
const std::vector<std::string> kBadIntegers = {"-5", "4294967297", "99999999999999999999999", "1.5", "nan", "inf",
                                               "5x", "0x10", " 3", "", "1e3", "+", "--3"};

struct IntegerOption {
    std::string command, option;
};

std::vector<IntegerOption> integerOptions() {
    const std::string cube = kCube;
    return {{"subdivide " + cube + " -o OUT", "--levels"},
            {"stats " + cube, "--levels"},
            {"demo --model " + cube, "--levels"},
            {"analyze --valence 3", "--rings"},
            {"analyze --valence 3", "--tangent-levels"},
            {"analyze --boundary-aspect " + std::string(PSUB_DATA) + "/grid4x4.obj", "--boundary-levels"},
            {"compare " + cube, "--levels"},
            {"compare " + cube, "--samples"},
            {"bench --quick", "--frames"},
            {"bench --quick", "--warmup"},
            {"bench --quick", "--levels"},
            {"bench --quick", "--extend-below"},
            {"bench --quick", "--max-faces"},
            {"bench --quick", "--max-factorized-faces"},
            {"bench --quick", "--torus"},
            {"play " + cube, "--levels"},
            {"play " + cube, "--frames"},
            {"play " + cube, "--msaa"},
            {"render " + cube + " -o OUT", "--levels"},
            {"render " + cube + " -o OUT", "--frames"},
            {"render " + cube + " -o OUT", "--msaa"}};
}

std::string withOut(std::string command, const fs::path& out) {
    const std::size_t at = command.find("OUT");
    if (at != std::string::npos) command.replace(at, 3, quoted(out / "x"));
    return command;
}

// Every option with every bad value. Under the sanitizers (a process start there costs about
// 0.2 s) option k takes the values j with j = k mod 4: every option and every value still run,
// through the one parser they share, in a quarter of the time.
TEST_F(HostileOptions, EveryIntegerOptionRefusesWhatIsNotAnIntegerInRange) {
    const std::vector<IntegerOption> options = integerOptions();
    ASSERT_GE(options.size(), 4u);
    for (std::size_t k = 0; k < options.size(); ++k)
        for (std::size_t j = 0; j < kBadIntegers.size(); ++j)
            if (!kSanitized || j % 4 == k % 4)
                expectUsageError(withOut(options[k].command, out()), options[k].option, kBadIntegers[j]);
}

TEST_F(HostileOptions, LevelsOutOfRangeNameTheRange) {
    const PsubRun r = psub("stats " + kCube + " --levels 31");
    EXPECT_EQ(r.status, 2);
    // 30: kMaxLevels in cli/main.cpp.
    EXPECT_TRUE(contains(oneLine(r), "--levels: expected a whole number in 0..30")) << r.err;
}

TEST_F(HostileOptions, LeadingZerosAreDecimalNotOctal) {
    const PsubRun r = psub("stats " + kCube + " --levels 010");
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(r.out, ", 10 P-S steps")) << r.out.substr(0, 200);
    const PsubRun plus = psub("stats " + kCube + " --levels +09");
    EXPECT_EQ(plus.status, 0) << plus.err;
    EXPECT_TRUE(contains(plus.out, ", 9 P-S steps")) << plus.out.substr(0, 200);
}

TEST_F(HostileOptions, ValenceListsAreDecimalAndRangeChecked) {
    // Valences run from 2 to 64 (cli/analyze.cpp): 1 and 65 are just outside.
    for (const char* value : {"99999999999999999999", "1", "65", "-3", "3,,4", "3..2", "0x10", "3.0", ""})
        expectUsageError("analyze", "--valence", value);
    const PsubRun r = psub("analyze --valence 0016,003 --rules paper --json");
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(r.out, "{\"n\": 16, ") && contains(r.out, "{\"n\": 3, ")) << r.out.substr(0, 300);
}

TEST_F(HostileOptions, MaxMemoryRefusesNegativeZeroOverflowAndJunk) {
    // 18446744073709551616 = 2^64 bytes, and 17179869184G = 2^34 GiB = 2^64 bytes too.
    for (const char* value : {"-5", "0", "18446744073709551616", "17179869184G", "5Q", "1.5G", "G", "", "nan"})
        expectUsageError("stats " + kCube, "--max-memory", value);
    expectUsageError("subdivide " + kCube + " -o " + quoted(out() / "x.obj"), "--max-memory", "-5");
}

TEST_F(HostileOptions, MaxMemoryUnitsAreBinary) {
    // 1K is 1024 bytes: far too little for 4 levels of the cube, and the message says so.
    // (Measured with `psub stats data/cube.obj --levels 4 --max-memory 1K`, 2026-12-03: the
    // estimate is 16.0 MiB, most of it the program itself.)
    const PsubRun r = psub("stats " + kCube + " --levels 4 --max-memory 1K");
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(oneLine(r), "(limit 1.0 KiB")) << r.err;
    const PsubRun fits = psub("stats " + kCube + " --levels 2 --max-memory 1GiB");
    EXPECT_EQ(fits.status, 0) << fits.err;
}

TEST_F(HostileOptions, RealOptionsRefuseNonFiniteNegativeAndJunk) {
    for (const char* value : {"nan", "NaN", "inf", "-inf", "infinity", "-30", "0", "1e400", "30fps", "0x1p4", ""})
        expectUsageError("play " + kCube + " --frames 1", "--anim-fps", value);
    for (const char* value : {"nan", "inf", "-1", "0", "1e999", "6s"})
        expectUsageError("bench --quick", "--frame-budget", value);
}

TEST_F(HostileOptions, SizesRefuseOverflowAndJunk) {
    // 4294967360 = 2^32 + 64 (64 if wrapped to 32 bits); 16385 is one over the 16384 limit
    // (cli/options.h).
    for (const char* value : {"4294967360x64", "64x4294967360", "-64x64", "64x-64", "0x64", "16385x64", "64x",
                                     "x64", "64X64", "64x64x64", "+64x64", "64 x64", "1e3x64", "12by7"}) {
        expectUsageError("render " + kCube + " -o " + quoted(out() / "x.png"), "--size", value);
        expectUsageError("play " + kCube, "--size", value);
        expectUsageError("figure5 -o " + quoted(out()), "--panel-size", value);
    }
}

TEST_F(HostileOptions, UnknownCommandListsTheCommandsAndSuggestsTheClosest) {
    const PsubRun r = psub("stat " + kCube);
    EXPECT_EQ(r.status, 2);
    const std::string line = oneLine(r);
    EXPECT_EQ(line.rfind("psub: unknown command 'stat' (did you mean 'stats'?); the commands are subdivide, stats, ", 0), 0u)
        << line;
    const PsubRun far = psub("frobnicate");
    EXPECT_EQ(far.status, 2);
    const std::string farLine = oneLine(far);
    EXPECT_FALSE(contains(farLine, "did you mean")) << farLine;
    EXPECT_TRUE(contains(farLine, "compare")) << farLine;
}

TEST_F(HostileOptions, NoCommandIsStillAUsageError) {
    const PsubRun r = psub("");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(linesOf(r.err).size(), 1u) << r.err;
}

// The parsers themselves (cli/numbers.h), on the edges the CLI cases above do not reach.
TEST(NumberPolicy, IntegersAreDecimalAndRangeChecked) {
    long long value = -1;
    EXPECT_EQ(cli::parseInteger("010", 0, 30, value), "");
    EXPECT_EQ(value, 10);
    EXPECT_EQ(cli::parseInteger("-0", 0, 30, value), "");
    EXPECT_EQ(value, 0);
    // LLONG_MAX = 2^63 - 1 = 9223372036854775807 is taken; one more is refused.
    EXPECT_EQ(cli::parseInteger("9223372036854775807", 0, LLONG_MAX, value), "");
    EXPECT_NE(cli::parseInteger("9223372036854775808", 0, LLONG_MAX, value), "");
    EXPECT_NE(cli::parseInteger("31", 0, 30, value), "");
    EXPECT_NE(cli::parseInteger("1 ", 0, 30, value), "");
}

TEST(NumberPolicy, BytesScaleByPowersOf1024AndRefuseOverflow) {
    std::uint64_t bytes = 0;
    EXPECT_EQ(cli::parseBytes("3G", bytes), "");
    EXPECT_EQ(bytes, 3ull << 30);
    EXPECT_EQ(cli::parseBytes("2kiB", bytes), "");  // either case of the prefix; then B or iB
    EXPECT_EQ(bytes, 2048u);
    EXPECT_NE(cli::parseBytes("2kIB", bytes), "");
    EXPECT_EQ(cli::parseBytes("512MiB", bytes), "");
    EXPECT_EQ(bytes, 512ull << 20);
    // 16777215 TiB = (2^24 - 1) * 2^40 = 2^64 - 2^40 bytes fits in 64 bits; 16777216 TiB = 2^64
    // does not, nor does 18446744073709551616 = 2^64 bytes.
    EXPECT_EQ(cli::parseBytes("16777215T", bytes), "");
    EXPECT_NE(cli::parseBytes("16777216T", bytes), "");
    EXPECT_NE(cli::parseBytes("18446744073709551616", bytes), "");
}

TEST(NumberPolicy, RealsMustBeFinite) {
    double value = 0;
    EXPECT_EQ(cli::parseReal("1e3", 1, 10000, value), "");
    EXPECT_EQ(value, 1000);
    EXPECT_EQ(cli::parseReal("+2.5", 1, 10000, value), "");
    EXPECT_EQ(value, 2.5);
    // 1e400 is beyond the largest double (1.8e308).
    for (const char* bad : {"nan", "inf", "1e400", "-1e400", "1,5", "0x10"}) EXPECT_NE(cli::parseReal(bad, -1e300, 1e300, value), "") << bad;
}

TEST(NumberPolicy, SizesAreTwoDecimalsInRange) {
    std::uint32_t w = 0, h = 0;
    EXPECT_EQ(cli::parseSize("0640x0480", 1, 16384, w, h), "");
    EXPECT_EQ(w, 640u);
    EXPECT_EQ(h, 480u);
    EXPECT_NE(cli::parseSize("4294967360x64", 1, 16384, w, h), "");  // 2^32 + 64: 64 if wrapped
}

}  // namespace
}  // namespace psub
