// The benchmark's output: markdown tables (stdout), JSON and an SVG plot written by hand.
#include "detail.h"

#include "psub/output.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdarg>
#include <fstream>
#include <map>
#include <sstream>

namespace psub::bench::detail {

std::string format(const char* fmt, ...) {
    char buffer[512];
    va_list args;
    va_start(args, fmt);
    std::vsnprintf(buffer, sizeof buffer, fmt, args);
    va_end(args);
    return buffer;
}

namespace {

// Milliseconds with about three significant digits.
std::string ms(double value) {
    if (value >= 100) return format("%.0f", value);
    if (value >= 10) return format("%.1f", value);
    if (value >= 1) return format("%.2f", value);
    return format("%.3g", value);
}

std::string ratio(double value) { return value >= 10 ? format("%.1fx", value) : format("%.2fx", value); }

std::string configName(const Record& r) {
    std::string name = r.evaluator + " " + std::to_string(r.threads) + "t";
    if (r.scheme == "cc") name += format(" %df", r.layoutFloats);
    return name;
}

const Record* fastest(const Report& report, const SizeResult& size, const std::string& scheme) {
    const Record* best = nullptr;
    for (const Record& r : report.records)
        if (r.model == size.model && r.ccLevel == size.k && r.scheme == scheme &&
            (!best || r.timing.median < best->timing.median))
            best = &r;
    return best;
}

const Record* find(const Report& report, const SizeResult& size, const std::string& evaluator, int threads) {
    for (const Record& r : report.records)
        if (r.model == size.model && r.ccLevel == size.k && r.evaluator == evaluator && r.threads == threads) return &r;
    return nullptr;
}

const Record* fastestBuild(const Report& report, const SizeResult& size, const std::string& scheme) {
    const Record* best = nullptr;
    for (const Record& r : report.records)
        if (r.model == size.model && r.ccLevel == size.k && r.scheme == scheme && (!best || r.buildMs < best->buildMs))
            best = &r;
    return best;
}

}  // namespace

void printMarkdown(const Report& report, std::FILE* out) {
    const Machine& m = report.machine;
    std::fprintf(out, "# psub bench: PSub (P-S) against OpenSubdiv (Catmull-Clark), same run\n\n");
    std::fprintf(out, "- Machine: %s, %d logical cores (%d threads used for \"all\"), %.1f GiB, %s\n", m.cpu.c_str(),
                 m.cores, m.threads, m.memoryGiB, m.kernel.c_str());
    std::fprintf(out, "- Compiler: %s; OpenSubdiv %s (Debian libosdCPU); the CPU tile kernel's %s clone\n",
                 m.compiler.c_str(), m.osdVersion.c_str(), m.tileKernel.c_str());
    std::fprintf(out, "- Date: %s; whole run %.0f s; meanwhile other processes used %.1f CPU-seconds and the "
                      "hypervisor stole %.1f (1-minute load average %.2f before, %.2f after)\n",
                 m.date.c_str(), report.seconds, report.otherCpuSeconds, report.stealSeconds, report.loadStart,
                 report.loadEnd);
    std::fprintf(out, "- Command: `%s`\n", report.command.c_str());
    std::fprintf(out,
                 "- Memory bandwidth, STREAM-style triad a[i] = b[i] + s*c[i] over 3 arrays of %zu doubles "
                 "(counting 3 x 8 B per element, the STREAM convention), best of several: "
                 "**%.1f GB/s on 1 thread, %.1f GB/s on %d threads**\n",
                 report.triadElements, report.triad1, report.triadAll, m.threads);
    std::fprintf(out,
                 "- Write-only bandwidth (streaming stores of %zu doubles): **%.1f GB/s on 1 thread, %.1f GB/s on %d "
                 "threads**. Floor = refined vertices x 12 B (finest positions written once) at the triad of the "
                 "record's thread count; x floor = frame time / floor; x write floor: the same at write-only "
                 "bandwidth; with normals: frames of positions and normals together, against 24 B per vertex at "
                 "the triad\n",
                 3 * report.triadElements, report.write1, report.writeAll, m.threads);
    if (m.threads > 1)
        std::fprintf(out,
                     "- Core to core round trip (a cache line from thread 0 to thread 1 and back): %.0f ns before the "
                     "frames, %.0f ns after (what threads pay to read each other's writes; on a virtual machine it "
                     "can change during the run)\n",
                     report.roundTripStart, report.roundTripEnd);
    std::fprintf(out,
                 "- Frames: control points move every frame (a small wave); per-frame time is the median (and "
                 "min) of %d timed frames after %d warm-up frames (fewer, at least 10, where %d frames would "
                 "take over %.0f s)\n",
                 report.frames.frames, report.frames.warmup, report.frames.frames, report.frames.budgetSeconds);
    if (report.frames.coldFrames > 0)
        std::fprintf(out,
                     "- Cold frames: then %d more, each after %zu MB written on every thread (%s); cold ms is their "
                     "median, cold x floor its multiple of the same floor, cold speed-up OpenSubdiv's fastest cold "
                     "frame over it\n",
                     report.frames.coldFrames, report.frames.flushBytes >> 20,
                     report.quick ? "the quick run's size, which tests the path, not the caches"
                                  : "twice the last-level cache: nothing of the last frame left in the caches, as "
                                    "after other work, or where the caches are smaller than the frame's tables and "
                                    "buffers");
    std::fprintf(out,
                 "- Sizes: P-S levels with the face count of Catmull-Clark level k (2k topological steps, the "
                 "paired method being the first when a face is not a quad)\n\n");

    std::fprintf(out, "## Face counts per step (the paper's Table I)\n\n");
    std::fprintf(out, "Column t = topological steps; Catmull-Clark level k sits under t = 2k. For a model that "
                      "needs preprocessing, t = 1 is the paired method and P-S level L is t = L + 1.\n\n");
    for (const ModelResult& model : report.models) {
        std::fprintf(out, "| %s | ", model.name.c_str());
        for (std::size_t t = 0; t < model.psFaces.size(); ++t) std::fprintf(out, "t=%zu | ", t);
        std::fprintf(out, "\n|---|");
        for (std::size_t t = 0; t < model.psFaces.size(); ++t) std::fprintf(out, "---:|");
        std::fprintf(out, "\n| P-S%s | ", model.preprocessed ? " (t=1: paired method)" : "");
        for (std::uint64_t f : model.psFaces) std::fprintf(out, "%llu | ", (unsigned long long)f);
        std::fprintf(out, "\n| Catmull-Clark | ");
        for (std::size_t t = 0; t < model.psFaces.size(); ++t) {
            if (t % 2 == 0 && t / 2 < model.ccFaces.size())
                std::fprintf(out, "%llu | ", (unsigned long long)model.ccFaces[t / 2]);
            else
                std::fprintf(out, " | ");
        }
        std::fprintf(out, "\n\n");
    }

    std::fprintf(out, "## PSub against OpenSubdiv's fastest configuration, per size\n\n");
    std::fprintf(out,
                 "Speed-up = OpenSubdiv's time / PSub's time (above 1: PSub is faster). OpenSubdiv's fastest = "
                 "the best of osd-cpu, osd-omp (1 and all threads), factorized and cascading tables, 3- and "
                 "4-float layouts; its build = refiner + the table of that configuration. Bandwidth fraction = "
                 "bytes per frame / median frame time / triad of the same thread count.\n\n");
    std::fprintf(out, "| model | k | faces CC / P-S | OSD fastest | OSD ms | PSub fastest | PSub ms | frame "
                      "speed-up | PSub per-level %dt | OSD build ms | PSub build ms (per-level) | build "
                      "speed-up | bw fraction PSub / OSD |\n",
                 report.machine.threads);
    std::fprintf(out, "|---|---:|---:|---|---:|---|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const SizeResult& size : report.sizes) {
        const Record* osd = fastest(report, size, "cc");
        const Record* ps = fastest(report, size, "ps");
        const Record* perLevel = find(report, size, "psub-cpu-perlevel", report.machine.threads);
        const Record* osdBuild = fastestBuild(report, size, "cc");
        const Record* psBuild = find(report, size, "psub-cpu-perlevel", 1);
        if (!osd || !ps || !perLevel || !osdBuild || !psBuild) continue;
        std::fprintf(out, "| %s | %d | %llu / %llu | %s | %s | %s | %s | **%s** | %s | %s | %s | **%s** | %.2f / %.2f |\n",
                     size.model.c_str(), size.k, (unsigned long long)size.ccFaces, (unsigned long long)size.psFaces,
                     configName(*osd).c_str(), ms(osd->timing.median).c_str(), configName(*ps).c_str(),
                     ms(ps->timing.median).c_str(), ratio(osd->timing.median / ps->timing.median).c_str(),
                     ratio(perLevel->ratioVsOsdBest).c_str(), ms(osdBuild->buildMs).c_str(),
                     ms(psBuild->buildMs).c_str(), ratio(osdBuild->buildMs / psBuild->buildMs).c_str(),
                     ps->bandwidthFraction, osd->bandwidthFraction);
    }

    std::fprintf(out, "\n## Every configuration\n\n");
    std::fprintf(out, "| model | k | scheme | levels | faces | evaluator | thr | layout | build ms (topology + "
                      "table) | frame ms median | min | frames | MB/frame | GB/s | bw fraction | speed-up vs OSD "
                      "fastest | build speed-up | max diff | floor ms | x floor | x write floor | table MB | "
                      "with normals ms | x floor (24 B) | cold ms | cold x floor | cold speed-up vs OSD fastest |\n");
    std::fprintf(out, "|---|---:|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const Record& r : report.records)
        std::fprintf(out, "| %s | %d | %s | %d | %llu | %s | %d | %d | %s (%s + %s) | %s | %s | %d | %.1f | %.1f | %.2f | %s | %s | %.1e | %.3f | %.1f | %.1f | %.1f | %s | %s | %s | %s | %s |\n",
                     r.model.c_str(), r.ccLevel, r.scheme == "ps" ? "P-S" : "CC", r.levels,
                     (unsigned long long)r.refinedFaces, r.evaluator.c_str(), r.threads, r.layoutFloats,
                     ms(r.buildMs).c_str(), ms(r.topologyMs).c_str(), ms(r.tableMs).c_str(),
                     ms(r.timing.median).c_str(), ms(r.timing.min).c_str(), r.timing.frames,
                     double(r.bytesPerFrame) / 1e6, r.gbs, r.bandwidthFraction, ratio(r.ratioVsOsdBest).c_str(),
                     ratio(r.buildRatioVsOsdBest).c_str(), r.maxDiff, r.floorMs, r.floorRatio, r.writeFloorRatio,
                     double(r.tableBytes) / 1e6, r.hasNormals ? ms(r.normalsTiming.median).c_str() : "-",
                     r.hasNormals ? format("%.1f", r.normalsFloorRatio).c_str() : "-",
                     r.timing.coldFrames > 0 ? ms(r.timing.coldMedian).c_str() : "-",
                     r.timing.coldFrames > 0 ? format("%.1f", r.coldFloorRatio).c_str() : "-",
                     r.coldRatioVsOsdBest > 0 ? ratio(r.coldRatioVsOsdBest).c_str() : "-");

    std::fprintf(out, "\n## Shape at matched sizes (refined positions from the evaluators, rest pose)\n\n");
    std::fprintf(out, "| model | input volume | input box diagonal | k | P-S levels | P-S faces | P-S volume | P-S "
                      "diagonal | CC faces | CC volume | CC diagonal | P-S / CC volume |\n");
    std::fprintf(out, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const SizeResult& size : report.sizes) {
        const ModelResult* model = nullptr;
        for (const ModelResult& candidate : report.models)
            if (candidate.name == size.model) model = &candidate;
        std::fprintf(out, "| %s | %.5g | %.5g | %d | %d | %llu | %.5g | %.5g | %llu | %.5g | %.5g | %.3f |\n",
                     size.model.c_str(), model ? model->input.volume : 0.0, model ? model->input.diagonal : 0.0,
                     size.k, size.psLevels, (unsigned long long)size.psFaces, size.ps.volume, size.ps.diagonal,
                     (unsigned long long)size.ccFaces, size.cc.volume, size.cc.diagonal,
                     size.cc.volume != 0 ? size.ps.volume / size.cc.volume : 0.0);
    }
    if (!report.notes.empty()) {
        std::fprintf(out, "\n## Notes\n\n");
        for (const std::string& note : report.notes) std::fprintf(out, "- %s\n", note.c_str());
    }
    if (!report.warnings.empty()) {
        std::fprintf(out, "\n## Warnings\n\n");
        for (const std::string& warning : report.warnings) std::fprintf(out, "- %s\n", warning.c_str());
    }
}

// ---------------------------------------------------------------------------------------
// JSON

namespace {

using Json = nlohmann::ordered_json;  // keeps the fields in the order written

}  // namespace

void writeJson(const Report& report, const std::string& path) {
    const Machine& m = report.machine;
    Json machine = {{"cpu", m.cpu}, {"cores", m.cores}, {"threads", m.threads}, {"memory_gib", m.memoryGiB},
                    {"compiler", m.compiler}, {"opensubdiv", m.osdVersion}, {"kernel", m.kernel}, {"date", m.date}, {"tile_kernel", m.tileKernel},
                    {"load_average_start", report.loadStart}, {"load_average_end", report.loadEnd},
                    {"other_cpu_seconds", report.otherCpuSeconds}, {"steal_seconds", report.stealSeconds}};

    Json models = Json::array(), sizes = Json::array(), results = Json::array();
    for (const ModelResult& model : report.models) {
        std::vector<std::uint64_t> sizeList(model.sizes.begin(), model.sizes.end());
        models.push_back({{"model", model.name}, {"path", model.path}, {"vertices", model.vertices},
                          {"faces", model.faces}, {"preprocessed", model.preprocessed},
                          {"ps_faces_per_step", model.psFaces}, {"cc_faces_per_level", model.ccFaces},
                          {"cc_levels_measured", sizeList}, {"input_volume", model.input.volume},
                          {"input_bbox_diagonal", model.input.diagonal}});
    }
    for (const SizeResult& size : report.sizes)
        sizes.push_back({{"model", size.model}, {"cc_levels", size.k}, {"ps_levels", size.psLevels},
                         {"cc_faces", size.ccFaces}, {"ps_faces", size.psFaces}, {"cc_volume", size.cc.volume},
                         {"cc_bbox_diagonal", size.cc.diagonal}, {"ps_volume", size.ps.volume},
                         {"ps_bbox_diagonal", size.ps.diagonal}, {"osd_best_frame_ms", size.osdBestFrameMs},
                         {"osd_best_build_ms", size.osdBestBuildMs},
                         {"osd_best_cold_frame_ms", size.osdBestColdFrameMs}});
    for (const Record& r : report.records) {
        Json o = {{"model", r.model}, {"scheme", r.scheme}, {"levels", r.levels}, {"cc_level", r.ccLevel},
                  {"refined_faces", r.refinedFaces}, {"refined_vertices", r.refinedVertices},
                  {"control_vertices", r.controlVertices}, {"evaluator", r.evaluator}, {"table", r.table},
                  {"threads", r.threads}, {"layout_floats", r.layoutFloats}};
        if (r.probe3 >= 0) o["probe_ms_3f"] = r.probe3, o["probe_ms_4f"] = r.probe4;
        o["build_ms"] = r.buildMs, o["topology_ms"] = r.topologyMs, o["table_ms"] = r.tableMs;
        if (r.buildWithCanonicalMs > 0) o["build_with_canonical_order_ms"] = r.buildWithCanonicalMs;
        o["build_repetitions"] = r.buildRepetitions, o["table_bytes"] = r.tableBytes, o["table_entries"] = r.tableEntries;
        o["frame_ms_median"] = r.timing.median, o["frame_ms_min"] = r.timing.min, o["frames"] = r.timing.frames;
        o["bytes_per_frame"] = r.bytesPerFrame, o["gbs"] = r.gbs, o["bandwidth_fraction"] = r.bandwidthFraction;
        o["ratio_vs_osd_best"] = r.ratioVsOsdBest, o["build_ratio_vs_osd_best"] = r.buildRatioVsOsdBest;
        o["max_diff_rel"] = r.maxDiff, o["volume"] = r.shape.volume, o["bbox_diagonal"] = r.shape.diagonal;
        o["floor_ms"] = r.floorMs, o["floor_ratio"] = r.floorRatio;
        o["write_floor_ms"] = r.writeFloorMs, o["write_floor_ratio"] = r.writeFloorRatio;
        if (r.timing.coldFrames > 0) {
            o["cold_frame_ms_median"] = r.timing.coldMedian, o["cold_frame_ms_min"] = r.timing.coldMin;
            o["cold_frames"] = r.timing.coldFrames, o["cold_floor_ratio"] = r.coldFloorRatio;
            o["cold_ratio_vs_osd_best"] = r.coldRatioVsOsdBest;
        }
        if (r.hasNormals) {
            o["normals_frame_ms_median"] = r.normalsTiming.median, o["normals_floor_ms"] = r.normalsFloorMs;
            o["normals_floor_ratio"] = r.normalsFloorRatio;
        }
        results.push_back(std::move(o));
    }
    const Json json = {
        {"machine", machine},
        {"date", m.date},
        {"command", report.command},
        {"triad_gbs", report.triadAll},
        {"triad_gbs_1thread", report.triad1},
        {"write_only_gbs", report.writeAll},
        {"write_only_gbs_1thread", report.write1},
        {"core_round_trip_ns", report.roundTripStart},
        {"core_round_trip_ns_end", report.roundTripEnd},
        {"triad", {{"elements_per_array", std::uint64_t(report.triadElements)}, {"bytes_per_element", 24},
                   {"convention", "STREAM: a[i] = b[i] + s*c[i], 3 arrays x 8 bytes per element, best of several runs"}}},
        {"frames", {{"warmup", report.frames.warmup}, {"frames", report.frames.frames},
                    {"budget_seconds", report.frames.budgetSeconds}, {"quick", report.quick},
                    {"cold_frames", report.frames.coldFrames}, {"cold_flush_bytes", std::uint64_t(report.frames.flushBytes)}}},
        {"max_faces", report.maxFaces},
        {"bytes_per_frame_model",
         "table bytes + for each pass: source vertices read once + destination vertices written once, "
         "at layout_floats x 4 bytes per vertex (per-level/cascading: one pass per level; factorized: "
         "control points -> finest level)"},
        {"seconds", report.seconds},
        {"models", models},
        {"sizes", sizes},
        {"results", results},
        {"notes", report.notes},
        {"warnings", report.warnings}};
    // Invalid UTF-8 (a model path in another encoding) is replaced, never a throw.
    writeOutput(path, json.dump(2, ' ', false, Json::error_handler_t::replace) + "\n");
}

// ---------------------------------------------------------------------------------------
// SVG

namespace {

std::string escape(const std::string& text) {
    std::string out;
    for (const char c : text) {
        if (c == '&') out += "&amp;";
        else if (c == '<') out += "&lt;";
        else if (c == '>') out += "&gt;";
        else if (c == '"') out += "&quot;";
        else out += c;
    }
    return out;
}

std::string facesLabel(double value) {
    if (value >= 1e6) return format("%gM", value / 1e6);
    if (value >= 1e3) return format("%gk", value / 1e3);
    return format("%g", value);
}

}  // namespace

void writeSvg(const Report& report, const std::string& path) {
    // Series: one per evaluator and thread count, points sorted by refined faces.
    std::map<std::string, std::vector<std::pair<double, double>>> series;
    std::vector<std::string> order;
    for (const Record& r : report.records) {
        if (r.timing.median <= 0) continue;
        const std::string key = r.evaluator + " (" + std::to_string(r.threads) + (r.threads == 1 ? " thread)" : " threads)");
        if (!series.count(key)) order.push_back(key);
        series[key].push_back({double(r.refinedFaces), r.timing.median});
    }
    // The floor: PSub's finest positions written once at the triad of all threads.
    const std::string floorKey = "floor: 12 B/vertex at triad (" + std::to_string(report.machine.threads) + " threads)";
    std::map<double, double> floor;
    for (const Record& r : report.records)
        if (r.scheme == "ps" && r.threads == report.machine.threads && r.floorMs > 0) floor[double(r.refinedFaces)] = r.floorMs;
    if (!floor.empty()) {
        order.push_back(floorKey);
        series[floorKey].assign(floor.begin(), floor.end());
    }
    double xMin = 1e300, xMax = 0, yMin = 1e300, yMax = 0;
    for (auto& [key, points] : series) {
        std::sort(points.begin(), points.end());
        for (const auto& [x, y] : points) {
            xMin = std::min(xMin, x), xMax = std::max(xMax, x);
            yMin = std::min(yMin, y), yMax = std::max(yMax, y);
        }
    }
    if (series.empty()) xMin = 1, xMax = 10, yMin = 1, yMax = 10;
    const double lx0 = std::floor(std::log10(xMin)), lx1 = std::max(lx0 + 1, std::ceil(std::log10(xMax)));
    const double ly0 = std::floor(std::log10(yMin)), ly1 = std::max(ly0 + 1, std::ceil(std::log10(yMax)));
    const double left = 90, right = 700, top = 80, bottom = 560, width = 1060, height = 630;
    auto X = [&](double x) { return left + (std::log10(x) - lx0) / (lx1 - lx0) * (right - left); };
    auto Y = [&](double y) { return bottom - (std::log10(y) - ly0) / (ly1 - ly0) * (bottom - top); };

    std::ostringstream svg;
    svg << format("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" viewBox=\"0 0 %.0f %.0f\" "
                  "font-family=\"sans-serif\" font-size=\"12\">\n",
                  width, height, width, height);
    svg << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    svg << format("<text x=\"%.0f\" y=\"28\" font-size=\"17\" font-weight=\"bold\">psub bench: per-frame time "
                  "against refined faces (PSub P-S vs OpenSubdiv Catmull-Clark, CPU)</text>\n",
                  left);
    svg << format("<text x=\"%.0f\" y=\"50\">%s</text>\n", left,
                  escape(report.machine.cpu + ", " + std::to_string(report.machine.cores) + " cores, " +
                         report.machine.compiler + ", OpenSubdiv " + report.machine.osdVersion + " - " +
                         report.machine.date)
                      .c_str());
    svg << format("<text x=\"%.0f\" y=\"66\" fill=\"#555\">triad %.1f GB/s (1 thread), %.1f GB/s (%d threads); "
                  "median of the timed frames; same run, same machine</text>\n",
                  left, report.triad1, report.triadAll, report.machine.threads);
    // Grid and ticks: decades, with 2 and 5 in between.
    for (double e = lx0; e <= lx1; ++e)
        for (double mantissa : {1.0, 2.0, 5.0}) {
            const double value = mantissa * std::pow(10.0, e);
            if (std::log10(value) > lx1 + 1e-9) continue;
            const double x = X(value);
            svg << format("<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"%s\"/>\n", x, top, x, bottom,
                          mantissa == 1 ? "#bbb" : "#eee");
            svg << format("<text x=\"%.1f\" y=\"%.0f\" text-anchor=\"middle\"%s>%s</text>\n", x, bottom + 18,
                          mantissa == 1 ? "" : " fill=\"#888\" font-size=\"10\"", facesLabel(value).c_str());
        }
    for (double e = ly0; e <= ly1; ++e)
        for (double mantissa : {1.0, 2.0, 5.0}) {
            const double value = mantissa * std::pow(10.0, e);
            if (std::log10(value) > ly1 + 1e-9) continue;
            const double y = Y(value);
            svg << format("<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"%s\"/>\n", left, y, right, y,
                          mantissa == 1 ? "#bbb" : "#eee");
            svg << format("<text x=\"%.0f\" y=\"%.1f\" text-anchor=\"end\"%s>%g</text>\n", left - 6, y + 4,
                          mantissa == 1 ? "" : " fill=\"#888\" font-size=\"10\"", value);
        }
    svg << format("<rect x=\"%.0f\" y=\"%.0f\" width=\"%.0f\" height=\"%.0f\" fill=\"none\" stroke=\"black\"/>\n", left,
                  top, right - left, bottom - top);
    svg << format("<text x=\"%.0f\" y=\"%.0f\" text-anchor=\"middle\" font-size=\"14\">refined faces (log scale; "
                  "every model, sorted by face count)</text>\n",
                  (left + right) / 2, bottom + 45);
    svg << format("<text transform=\"translate(%.0f %.0f) rotate(-90)\" text-anchor=\"middle\" font-size=\"14\">"
                  "per-frame time, median [ms] (log scale)</text>\n",
                  left - 55, (top + bottom) / 2);

    const char* colours[] = {"#1f77b4", "#2ca02c", "#17becf", "#9467bd", "#d62728", "#ff7f0e",
                             "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#000000", "#aec7e8"};
    double legendY = top + 10;
    svg << format("<text x=\"%.0f\" y=\"%.0f\" font-weight=\"bold\">evaluator (threads)</text>\n", right + 20, legendY);
    for (std::size_t i = 0; i < order.size(); ++i) {
        const auto& points = series[order[i]];
        const char* colour = colours[i % (sizeof colours / sizeof *colours)];
        const bool osd = order[i].rfind("osd", 0) == 0 || order[i] == floorKey;
        std::string line;
        for (const auto& [x, y] : points) line += format("%.1f,%.1f ", X(x), Y(y));
        svg << format("<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"2\"%s points=\"%s\"/>\n", colour,
                      osd ? " stroke-dasharray=\"6 3\"" : "", line.c_str());
        for (const auto& [x, y] : points)
            svg << format("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3\" fill=\"%s\"/>\n", X(x), Y(y), colour);
        legendY += 20;
        svg << format("<line x1=\"%.0f\" y1=\"%.0f\" x2=\"%.0f\" y2=\"%.0f\" stroke=\"%s\" stroke-width=\"2\"%s/>\n",
                      right + 20, legendY - 4, right + 50, legendY - 4, colour, osd ? " stroke-dasharray=\"6 3\"" : "");
        svg << format("<text x=\"%.0f\" y=\"%.0f\">%s</text>\n", right + 56, legendY, escape(order[i]).c_str());
    }
    legendY += 30;
    svg << format("<text x=\"%.0f\" y=\"%.0f\" fill=\"#555\">solid: PSub; dashed: OpenSubdiv</text>\n", right + 20,
                  legendY);
    svg << format("<text x=\"%.0f\" y=\"%.0f\" fill=\"#555\">command: %s</text>\n", left, height - 12,
                  escape(report.command).c_str());
    svg << "</svg>\n";
    writeOutput(path, svg.str());
}

}  // namespace psub::bench::detail
