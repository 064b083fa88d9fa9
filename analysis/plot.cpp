// A small PNG of a P-S / Catmull-Clark comparison: ratio bars and distance histograms, drawn
// into a psub::Image (psub/image.h: captions with stb_easy_font, PNG with libpng).
#include "psub/analysis.h"

#include "psub/image.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

namespace psub {
namespace {

constexpr Rgba kBlack{30, 30, 30, 255}, kGrey{190, 190, 190, 255}, kPs{214, 96, 40, 255}, kCc{40, 110, 190, 255};

int textWidth(const std::string& text) { return textSize(text, 1)[0]; }

std::string format(const char* pattern, double value) {
    char text[64];
    std::snprintf(text, sizeof text, pattern, value);
    return text;
}

}  // namespace

void writeFidelityPlot(const std::string& path, const Fidelity& f, const std::string& title) {
    constexpr int width = 960, height = 460;
    Image canvas = filledImage(width, height, {255, 255, 255, 255});
    drawText(canvas, 20, 14, title, 2, kBlack);
    drawText(canvas, 20, 40,
                "P-S " + std::to_string(f.psSteps) + " steps (" + std::to_string(f.psFaces) + " faces) vs Catmull-Clark " +
                    std::to_string(f.ccLevels) + " levels (" + std::to_string(f.ccFaces) + " faces)", 1, kBlack);

    // Left: P-S / Catmull-Clark ratios as bars, with the line at 1.
    const int left = 60, top = 80, bottom = 400, barsRight = 380;
    const double ratios[3] = {f.cc.volume != 0 ? f.ps.volume / f.cc.volume : 0, f.cc.area != 0 ? f.ps.area / f.cc.area : 0,
                              f.cc.diagonal() != 0 ? f.ps.diagonal() / f.cc.diagonal() : 0};
    const char* names[3] = {"volume", "area", "box diag"};
    double top1 = 1.2;
    for (double r : ratios) top1 = std::max(top1, std::ceil(std::abs(r) * 5) / 5);
    const auto yOf = [&](double r) { return bottom - int(std::lround(std::clamp(r, 0.0, top1) / top1 * (bottom - top))); };
    drawText(canvas, left, top - 16, "P-S / Catmull-Clark", 1, kBlack);
    fillRect(canvas, left, top, left, bottom, kBlack);
    fillRect(canvas, left, bottom, barsRight, bottom, kBlack);
    for (double tick = 0; tick <= top1 + 1e-9; tick += 0.2) {
        fillRect(canvas, left - 4, yOf(tick), left, yOf(tick), kBlack);
        drawText(canvas, left - 34, yOf(tick) - 3, format("%.1f", tick), 1, kBlack);
    }
    fillRect(canvas, left + 1, yOf(1), barsRight, yOf(1), kGrey);
    for (int b = 0; b < 3; ++b) {
        const int x0 = left + 20 + b * 105, x1 = x0 + 70;
        fillRect(canvas, x0, yOf(ratios[b]), x1, bottom - 1, kPs);
        drawText(canvas, x0 + 35 - textWidth(names[b]) / 2, bottom + 8, names[b], 1, kBlack);
        drawText(canvas, x0 + 35 - textWidth(format("%.3f", ratios[b])) / 2, yOf(ratios[b]) - 12, format("%.3f", ratios[b]), 1, kBlack);
    }

    // Right: histograms of the sampled distances / box diagonal, both directions.
    const int hLeft = 470, hRight = 930;
    const double diagonal = std::max(f.cc.diagonal(), 1e-300);
    const double largest = std::max(f.hausdorff() / diagonal, 1e-12);
    constexpr int bins = 40;
    std::vector<double> psBins(bins, 0), ccBins(bins, 0);
    const auto bin = [&](double d) { return std::min(bins - 1, int(d / diagonal / largest * bins)); };
    for (double d : f.psToCc) ++psBins[std::size_t(bin(d))];
    for (double d : f.ccToPs) ++ccBins[std::size_t(bin(d))];
    for (double& b : psBins) b /= double(std::max<std::size_t>(f.psToCc.size(), 1));
    for (double& b : ccBins) b /= double(std::max<std::size_t>(f.ccToPs.size(), 1));
    double peak = 1e-12;
    for (int b = 0; b < bins; ++b) peak = std::max({peak, psBins[std::size_t(b)], ccBins[std::size_t(b)]});
    drawText(canvas, hLeft, top - 16, "distance / box diagonal (fraction of samples)", 1, kBlack);
    fillRect(canvas, hLeft, top, hLeft, bottom, kBlack);
    fillRect(canvas, hLeft, bottom, hRight, bottom, kBlack);
    const int binWidth = (hRight - hLeft - 4) / bins;
    for (int b = 0; b < bins; ++b) {
        const int x0 = hLeft + 2 + b * binWidth;
        const int half = binWidth / 2;
        fillRect(canvas, x0, bottom - 1 - int(psBins[std::size_t(b)] / peak * (bottom - top - 20)), x0 + half - 1, bottom - 1, kPs);
        fillRect(canvas, x0 + half, bottom - 1 - int(ccBins[std::size_t(b)] / peak * (bottom - top - 20)), x0 + binWidth - 1, bottom - 1, kCc);
    }
    drawText(canvas, hLeft, bottom + 8, "0", 1, kBlack);
    const std::string maxLabel = format("%.3g", largest) + " (Hausdorff)";
    drawText(canvas, hRight - textWidth(maxLabel), bottom + 8, maxLabel, 1, kBlack);
    drawText(canvas, hLeft + 8, top, format("%.2f", peak), 1, kBlack);
    fillRect(canvas, hLeft + 150, top + 14, hLeft + 160, top + 22, kPs);
    drawText(canvas, hLeft + 166, top + 15, "P-S to Catmull-Clark", 1, kBlack);
    fillRect(canvas, hLeft + 150, top + 30, hLeft + 160, top + 38, kCc);
    drawText(canvas, hLeft + 166, top + 31, "Catmull-Clark to P-S", 1, kBlack);
    drawText(canvas, hLeft, bottom + 26,
                "mean " + format("%.3g", f.meanDistance() / diagonal) + "   Hausdorff " + format("%.3g", f.hausdorff() / diagonal) +
                    " of the box diagonal", 1, kBlack);
    writePng(path, canvas);
}

}  // namespace psub
