// A small PNG of a P-S / Catmull-Clark comparison: ratio bars and distance histograms, drawn
// into an RGB raster with a 5x7 bitmap font and encoded by libpng.
#include "psub/analysis.h"

#include <png.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

namespace psub {
namespace {

struct Colour {
    std::uint8_t r, g, b;
};

constexpr Colour kBlack{30, 30, 30}, kGrey{190, 190, 190}, kPs{214, 96, 40}, kCc{40, 110, 190}, kWhite{255, 255, 255};

// 5x7 glyphs, one string of 7 rows of 5 columns each ('#' = ink). Lower case is drawn as upper.
struct Glyph {
    char c;
    const char* rows;
};
constexpr Glyph kFont[] = {
    {'0', " ### #   ##  ### # ###  ##   # ### "}, {'1', "  #   ##    #    #    #    #   ### "},
    {'2', " ### #   #    #   #   #   #    ####"}, {'3', "#####   #   #     #     ##   # ### "},
    {'4', "   #   ##  # # #  # #####   #    # "}, {'5', "######    ####     #    ##   # ### "},
    {'6', "  ##  #   #    #### #   ##   # ### "}, {'7', "#####    #   #   #   #    #    #   "},
    {'8', " ### #   ##   # ### #   ##   # ### "}, {'9', " ### #   ##   # ####    #   #  ##  "},
    {'A', " ### #   ##   #######   ##   ##   #"}, {'B', "#### #   ##   ##### #   ##   ##### "},
    {'C', " ### #   ##    #    #    #   # ### "}, {'D', "###  #  # #   ##   ##   ##  # ###  "},
    {'E', "######    #    #### #    #    #####"}, {'F', "######    #    #### #    #    #    "},
    {'G', " ### #   ##    # ####   ##   # ####"}, {'H', "#   ##   ##   #######   ##   ##   #"},
    {'I', " ###   #    #    #    #    #   ### "}, {'J', "  ###   #    #    #    # #  #  ##  "},
    {'K', "#   ##  # # #  ##   # #  #  # #   #"}, {'L', "#    #    #    #    #    #    #####"},
    {'M', "#   ### ### # ## # ##   ##   ##   #"}, {'N', "#   ##   ###  ## # ##  ###   ##   #"},
    {'O', " ### #   ##   ##   ##   ##   # ### "}, {'P', "#### #   ##   ##### #    #    #    "},
    {'Q', " ### #   ##   ##   ## # ##  #  ## #"}, {'R', "#### #   ##   ##### # #  #  # #   #"},
    {'S', " #####    #     ###     #    ##### "}, {'T', "#####  #    #    #    #    #    #  "},
    {'U', "#   ##   ##   ##   ##   ##   # ### "}, {'V', "#   ##   ##   ##   ##   # # #   #  "},
    {'W', "#   ##   ##   ## # ## # ## # # # # "}, {'X', "#   ##   # # #   #   # # #   ##   #"},
    {'Y', "#   ##   # # #   #    #    #    #  "}, {'Z', "#####    #   #   #   #   #    #####"},
    {'.', "                         ##   ##   "}, {',', "                     ##    #   #   "},
    {'-', "               ###                 "}, {'+', "       #    #  #####  #    #       "},
    {'/', "    #    #   #   #   #    #    #   "}, {':', "      ##   ##        ##   ##       "},
    {'(', "   #   #   #    #    #     #     # "}, {')', " #     #     #    #    #   #   #   "},
    {'=', "          #####     #####          "}, {'%', "##   ##  #   #   #   #   #  ##   ##"},
    {'>', " #     #     #     #   #   #   #   "}, {'<', "   #   #   #   #     #     #     # "},
    {'_', "                              #####"}, {'|', "  #    #    #    #    #    #    #  "},
};

class Canvas {
public:
    Canvas(int width, int height) : width_(width), height_(height), pixels_(std::size_t(width) * std::size_t(height) * 3, 255) {}

    void set(int x, int y, Colour c) {
        if (x < 0 || y < 0 || x >= width_ || y >= height_) return;
        std::uint8_t* p = &pixels_[(std::size_t(y) * std::size_t(width_) + std::size_t(x)) * 3];
        p[0] = c.r, p[1] = c.g, p[2] = c.b;
    }
    void fill(int x0, int y0, int x1, int y1, Colour c) {
        for (int y = std::min(y0, y1); y <= std::max(y0, y1); ++y)
            for (int x = std::min(x0, x1); x <= std::max(x0, x1); ++x) set(x, y, c);
    }
    // Text at (x, y) top-left, `scale` pixels per font dot.
    void text(int x, int y, const std::string& s, Colour c, int scale = 1) {
        for (char raw : s) {
            const char ch = (raw >= 'a' && raw <= 'z') ? char(raw - 'a' + 'A') : raw;
            for (const Glyph& g : kFont) {
                if (g.c != ch) continue;
                for (int row = 0; row < 7; ++row)
                    for (int col = 0; col < 5; ++col)
                        if (g.rows[row * 5 + col] == '#') fill(x + col * scale, y + row * scale, x + col * scale + scale - 1, y + row * scale + scale - 1, c);
            }
            x += 6 * scale;
        }
    }
    static int textWidth(const std::string& s, int scale = 1) { return int(s.size()) * 6 * scale; }

    std::string encode() const {
        std::string bytes;
        png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
        png_infop info = png ? png_create_info_struct(png) : nullptr;
        if (!png || !info || setjmp(png_jmpbuf(png))) {
            png_destroy_write_struct(&png, &info);
            throw InputError("libpng could not encode the plot");
        }
        png_set_write_fn(
            png, &bytes,
            [](png_structp p, png_bytep data, png_size_t length) {
                static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<const char*>(data), length);
            },
            nullptr);
        png_set_IHDR(png, info, png_uint_32(width_), png_uint_32(height_), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                     PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
        png_write_info(png, info);
        for (int y = 0; y < height_; ++y)
            png_write_row(png, const_cast<png_bytep>(&pixels_[std::size_t(y) * std::size_t(width_) * 3]));
        png_write_end(png, nullptr);
        png_destroy_write_struct(&png, &info);
        return bytes;
    }

private:
    int width_, height_;
    std::vector<std::uint8_t> pixels_;
};

std::string format(const char* pattern, double value) {
    char text[64];
    std::snprintf(text, sizeof text, pattern, value);
    return text;
}

}  // namespace

void writeFidelityPlot(const std::string& path, const Fidelity& f, const std::string& title) {
    constexpr int width = 960, height = 460;
    Canvas canvas(width, height);
    canvas.text(20, 14, title, kBlack, 2);
    canvas.text(20, 40,
                "P-S " + std::to_string(f.psSteps) + " steps (" + std::to_string(f.psFaces) + " faces) vs Catmull-Clark " +
                    std::to_string(f.ccLevels) + " levels (" + std::to_string(f.ccFaces) + " faces)",
                kBlack);

    // Left: P-S / Catmull-Clark ratios as bars, with the line at 1.
    const int left = 60, top = 80, bottom = 400, barsRight = 380;
    const double ratios[3] = {f.cc.volume != 0 ? f.ps.volume / f.cc.volume : 0, f.cc.area != 0 ? f.ps.area / f.cc.area : 0,
                              f.cc.diagonal() != 0 ? f.ps.diagonal() / f.cc.diagonal() : 0};
    const char* names[3] = {"volume", "area", "box diag"};
    double top1 = 1.2;
    for (double r : ratios) top1 = std::max(top1, std::ceil(std::abs(r) * 5) / 5);
    const auto yOf = [&](double r) { return bottom - int(std::lround(std::clamp(r, 0.0, top1) / top1 * (bottom - top))); };
    canvas.text(left, top - 16, "P-S / Catmull-Clark", kBlack);
    canvas.fill(left, top, left, bottom, kBlack);
    canvas.fill(left, bottom, barsRight, bottom, kBlack);
    for (double tick = 0; tick <= top1 + 1e-9; tick += 0.2) {
        canvas.fill(left - 4, yOf(tick), left, yOf(tick), kBlack);
        canvas.text(left - 34, yOf(tick) - 3, format("%.1f", tick), kBlack);
    }
    canvas.fill(left + 1, yOf(1), barsRight, yOf(1), kGrey);
    for (int b = 0; b < 3; ++b) {
        const int x0 = left + 20 + b * 105, x1 = x0 + 70;
        canvas.fill(x0, yOf(ratios[b]), x1, bottom - 1, kPs);
        canvas.text(x0 + 35 - Canvas::textWidth(names[b]) / 2, bottom + 8, names[b], kBlack);
        canvas.text(x0 + 35 - Canvas::textWidth(format("%.3f", ratios[b])) / 2, yOf(ratios[b]) - 12, format("%.3f", ratios[b]), kBlack);
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
    canvas.text(hLeft, top - 16, "distance / box diagonal (fraction of samples)", kBlack);
    canvas.fill(hLeft, top, hLeft, bottom, kBlack);
    canvas.fill(hLeft, bottom, hRight, bottom, kBlack);
    const int binWidth = (hRight - hLeft - 4) / bins;
    for (int b = 0; b < bins; ++b) {
        const int x0 = hLeft + 2 + b * binWidth;
        const int half = binWidth / 2;
        canvas.fill(x0, bottom - 1 - int(psBins[std::size_t(b)] / peak * (bottom - top - 20)), x0 + half - 1, bottom - 1, kPs);
        canvas.fill(x0 + half, bottom - 1 - int(ccBins[std::size_t(b)] / peak * (bottom - top - 20)), x0 + binWidth - 1, bottom - 1, kCc);
    }
    canvas.text(hLeft, bottom + 8, "0", kBlack);
    const std::string maxLabel = format("%.3g", largest) + " (Hausdorff)";
    canvas.text(hRight - Canvas::textWidth(maxLabel), bottom + 8, maxLabel, kBlack);
    canvas.text(hLeft + 8, top, format("%.2f", peak), kBlack);
    canvas.fill(hLeft + 150, top + 14, hLeft + 160, top + 22, kPs);
    canvas.text(hLeft + 166, top + 15, "P-S to Catmull-Clark", kBlack);
    canvas.fill(hLeft + 150, top + 30, hLeft + 160, top + 38, kCc);
    canvas.text(hLeft + 166, top + 31, "Catmull-Clark to P-S", kBlack);
    canvas.text(hLeft, bottom + 26,
                "mean " + format("%.3g", f.meanDistance() / diagonal) + "   Hausdorff " + format("%.3g", f.hausdorff() / diagonal) +
                    " of the box diagonal",
                kBlack);
    canvas.fill(0, height - 1, width - 1, height - 1, kWhite);
    writeFileAtomic(path, canvas.encode());
}

}  // namespace psub
