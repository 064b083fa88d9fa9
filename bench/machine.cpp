// The machine the benchmark ran on, its memory bandwidth (STREAM-style triad), the progress
// line, the animation of the control points and small helpers.
#include "detail.h"
#include "psub/evaluator.h"

#if defined(__SSE2__)
#include <immintrin.h>
#endif
#include <cstdint>

#include <opensubdiv/version.h>

#include <omp.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <ctime>
#include <fstream>
#include <memory>
#include <sstream>
#include <thread>
#include <vector>

namespace psub::bench::detail {

#define PSUB_BENCH_STR2(x) #x
#define PSUB_BENCH_STR(x) PSUB_BENCH_STR2(x)

void flushCaches(std::size_t bytes) {
    static std::vector<unsigned char> buffer;
    static unsigned char value = 0;
    if (buffer.size() < bytes) buffer.assign(bytes, 0);
    ++value;
    const std::int64_t lines = std::int64_t(bytes / 64);
    unsigned char* data = buffer.data();
#pragma omp parallel for schedule(static)
    for (std::int64_t line = 0; line < lines; ++line) data[64 * line] = value;
}

std::size_t coldFlushBytes() {
    const long lastLevel = ::sysconf(_SC_LEVEL3_CACHE_SIZE);
    const std::size_t twice = lastLevel > 0 ? 2 * std::size_t(lastLevel) : 0;
    return std::clamp(twice, std::size_t(256) << 20, std::size_t(1) << 30);
}

Machine describeMachine() {
    Machine m;
    std::ifstream cpuinfo("/proc/cpuinfo");
    for (std::string line; std::getline(cpuinfo, line);)
        if (line.rfind("model name", 0) == 0) {
            const std::size_t colon = line.find(':');
            m.cpu = colon == std::string::npos ? line : line.substr(colon + 2);
            break;
        }
    if (m.cpu.empty()) m.cpu = "unknown CPU";
    m.tileKernel = tileKernelInstructions();
    const long cores = ::sysconf(_SC_NPROCESSORS_ONLN);
    m.cores = cores > 0 ? int(cores) : 1;
    m.threads = omp_get_max_threads();
    const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
    m.memoryGiB = pages > 0 && pageSize > 0 ? double(pages) * double(pageSize) / (1024.0 * 1024 * 1024) : 0;
#if defined(__clang__)
    m.compiler = "clang " __clang_version__;
#elif defined(__GNUC__)
    m.compiler = "GCC " __VERSION__;
#else
    m.compiler = "unknown compiler";
#endif
    m.osdVersion = PSUB_BENCH_STR(OPENSUBDIV_VERSION_MAJOR) "." PSUB_BENCH_STR(OPENSUBDIV_VERSION_MINOR) "." PSUB_BENCH_STR(
        OPENSUBDIV_VERSION_PATCH);
    struct utsname name {};
    if (::uname(&name) == 0) m.kernel = std::string(name.sysname) + " " + name.release;
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    ::gmtime_r(&now, &utc);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", &utc);
    m.date = date;
    return m;
}

CpuTimes readCpuTimes() {
    CpuTimes times;
    const double tick = double(::sysconf(_SC_CLK_TCK));
    std::ifstream stat("/proc/stat");
    std::string label;
    double user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0, steal = 0;
    if (stat >> label >> user >> nice >> system >> idle >> iowait >> irq >> softirq >> steal && label == "cpu") {
        times.busy = (user + nice + system + irq + softirq) / tick;
        times.steal = steal / tick;
    }
    // /proc/self/stat: utime and stime are fields 14 and 15, after the parenthesised name.
    std::ifstream self("/proc/self/stat");
    std::string line;
    std::getline(self, line);
    const std::size_t close = line.rfind(')');
    if (close != std::string::npos) {
        std::istringstream fields(line.substr(close + 2));
        std::string field;
        double utime = 0, stime = 0;
        for (int i = 3; i <= 15 && fields >> field; ++i) {
            if (i == 14) utime = std::stod(field);
            if (i == 15) stime = std::stod(field);
        }
        times.self = (utime + stime) / tick;
    }
    return times;
}

double measureTriad(int threads, std::size_t elements, int repetitions) {
    // Uninitialised on purpose: the first touch below places pages near the thread using them.
    std::unique_ptr<double[]> a(new double[elements]), b(new double[elements]), c(new double[elements]);
    double* pa = a.get();
    double* pb = b.get();
    double* pc = c.get();
    const long n = long(elements);
#pragma omp parallel for num_threads(threads) schedule(static)
    for (long i = 0; i < n; ++i) {
        pa[i] = 0;
        pb[i] = 1;
        pc[i] = 2;
    }
    const double s = 3;
    double best = 1e300;
    for (int rep = 0; rep < repetitions; ++rep) {
        const auto start = Clock::now();
#pragma omp parallel for num_threads(threads) schedule(static)
        for (long i = 0; i < n; ++i) pa[i] = pb[i] + s * pc[i];
        best = std::min(best, msSince(start));
    }
    // Keep the stores observable.
    volatile double sink = pa[elements / 2];
    (void)sink;
    return 3.0 * 8.0 * double(elements) / (best * 1e-3) / 1e9;
}

double measureWriteOnly(int threads, std::size_t elements, int repetitions) {
    std::unique_ptr<double[]> a(new double[elements + 1]);
    // 16-byte aligned start for the streaming stores.
    double* pa = a.get() + ((reinterpret_cast<std::uintptr_t>(a.get()) % 16) ? 1 : 0);
    const long pairs = long(elements / 2);
#pragma omp parallel for num_threads(threads) schedule(static)
    for (long i = 0; i < pairs; ++i) pa[2 * i] = pa[2 * i + 1] = 0;
    double best = 1e300;
    for (int rep = 0; rep < repetitions; ++rep) {
        const double value = rep;
        const auto start = Clock::now();
#if defined(__SSE2__)
        const __m128d v = _mm_set1_pd(value);
#pragma omp parallel num_threads(threads)
        {
#pragma omp for schedule(static)
            for (long i = 0; i < pairs; ++i) _mm_stream_pd(pa + 2 * i, v);
            _mm_sfence();  // each thread's streaming stores drained before the time is taken
        }
#else
#pragma omp parallel for num_threads(threads) schedule(static)
        for (long i = 0; i < pairs; ++i) pa[2 * i] = pa[2 * i + 1] = value;
#endif
        best = std::min(best, msSince(start));
    }
    volatile double sink = pa[elements / 2];
    (void)sink;
    return 8.0 * double(2 * pairs) / (best * 1e-3) / 1e9;
}

double measureCoreRoundTrip(int rounds) {
    if (omp_get_max_threads() < 2 || std::thread::hardware_concurrency() < 2) return 0;
    std::vector<double> runs;
    for (int run = 0; run < 5; ++run) {
        std::atomic<int> turn{0};
        std::atomic<bool> late{false};  // past 0.2 s (a busy machine, a thread not running): stop
        double ns = 0;
#pragma omp parallel num_threads(2)
        {
            const int me = omp_get_thread_num();
            const auto start = Clock::now();
            int i = 0;
            for (; i < rounds && omp_get_num_threads() == 2 && !late.load(std::memory_order_relaxed); ++i) {
                for (unsigned spins = 1; turn.load(std::memory_order_acquire) != 2 * i + me; ++spins) {
                    if (spins % 4096 == 0 && msSince(start) > 200) late.store(true, std::memory_order_relaxed);
                    if (late.load(std::memory_order_relaxed)) break;
                }
                turn.store(2 * i + me + 1, std::memory_order_release);
            }
            if (me == 0) ns = i > 0 ? msSince(start) * 1e6 / i : 0;
        }
        runs.push_back(ns);
    }
    std::sort(runs.begin(), runs.end());
    return runs[runs.size() / 2];
}

Progress::Progress() : tty_(::isatty(2) != 0) {}

void Progress::show(const std::string& line) {
    if (tty_) {
        std::fprintf(stderr, "\r%s", line.c_str());
        if (line.size() < last_) std::fprintf(stderr, "%*s", int(last_ - line.size()), "");
        last_ = line.size();
    } else {
        std::fprintf(stderr, "%s\n", line.c_str());
    }
    std::fflush(stderr);
}

void Progress::done() {
    if (tty_ && last_ > 0) std::fprintf(stderr, "\r%*s\r", int(last_), "");
    last_ = 0;
    std::fflush(stderr);
}

Animation::Animation(std::span<const double> positions, double diagonal)
    : rest(positions.begin(), positions.end()),
      amplitude(float(0.01 * diagonal)),
      wavenumber(float(diagonal > 0 ? 6.0 / diagonal : 1.0)) {}

void Animation::write(int frame, float* destination, unsigned stride) const {
    const float phase = 0.2f * float(frame);
    const std::size_t n = count();
    for (std::size_t v = 0; v < n; ++v) {
        const float* p = &rest[3 * v];
        float* out = destination + v * stride;
        out[0] = p[0];
        out[1] = p[1] + amplitude * std::sin(wavenumber * p[0] + phase);
        out[2] = p[2];
        if (stride > 3) out[3] = 1;
    }
}

void Animation::writeRest(float* destination, unsigned stride) const {
    const std::size_t n = count();
    for (std::size_t v = 0; v < n; ++v) {
        float* out = destination + v * stride;
        for (int axis = 0; axis < 3; ++axis) out[axis] = rest[3 * v + std::size_t(axis)];
        if (stride > 3) out[3] = 1;
    }
}

double boxDiagonal(std::span<const double> positions) {
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300}, d = 0;
    for (std::size_t i = 0; i < positions.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], positions[i]);
        hi[i % 3] = std::max(hi[i % 3], positions[i]);
    }
    for (int a = 0; a < 3; ++a) d += (hi[a] - lo[a]) * (hi[a] - lo[a]);
    return std::sqrt(d);
}

double maxDifference(const float* a, unsigned strideA, const float* b, unsigned strideB,
                     std::size_t vertexCount) {
    double worst = 0;
    for (std::size_t v = 0; v < vertexCount; ++v)
        for (std::size_t axis = 0; axis < 3; ++axis) {
            const double d = std::abs(double(a[v * strideA + axis]) - double(b[v * strideB + axis]));
            if (!(d <= worst)) worst = d;  // NaN propagates as the worst
        }
    return worst;
}

}  // namespace psub::bench::detail
