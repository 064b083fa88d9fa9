// psub figure5: the paper's Figure 5 rebuilt (its picture was lost from our copy): per model,
// one PNG row of the input, P-S and Catmull-Clark at equal face counts, one camera per row;
// and the paper's Table I (faces per step of both schemes) as a table and a log-scale plot.
// psub figure-shape: one such row of the cube for the rules, paper beside shape.
#include "figure5.h"

#include "options.h"
#include "render.h"

#include "psub/catmark.h"
#include "psub/output.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace psub::cli {
namespace {

// One row of the figure: a model, the P-S steps and the Catmull-Clark levels shown.
struct Row {
    const char* name;  // file in the data directory, and the PNG's name
    int psSteps;       // topological steps: the paired method, when the model needs it, counts as one
    int ccLevels;
    Wireframe wireframe;
};

constexpr Row kRows[] = {{"cow", 2, 1, Wireframe::None}, {"cube", 4, 2, Wireframe::Refined}};

std::string withThousands(std::uint64_t value) {
    std::string digits = std::to_string(value), out;
    for (std::size_t i = 0; i < digits.size(); ++i) {
        if (i && (digits.size() - i) % 3 == 0) out += ',';
        out += digits[i];
    }
    return out;
}

std::string faces(const Drawable& d) { return withThousands(d.surface.faceOffsets.size() - 1) + " faces"; }

struct Model {
    Row row;
    Mesh mesh;
    CheckedMesh checked;
};

// The row's three panels, drawn with one camera (framing the input) so sizes compare.
Image drawRow(VulkanContext& context, const Model& model, const Figure5Options& o) {
    const Row& row = model.row;
    const Mesh& mesh = model.mesh;
    const CheckedMesh& checked = model.checked;
    const bool paired = needsPreprocessing(mesh.faces, checked.connectivity, Preprocess::Auto);
    const int levels = row.psSteps - (paired ? 1 : 0);
    const Drawable panels[3] = {drawableCC(context, Backend::Cpu, mesh, 0),
                                drawablePS(context, Backend::Cpu, mesh, checked, levels),
                                drawableCC(context, Backend::Cpu, mesh, row.ccLevels)};
    const std::string ps = "P-S " + std::to_string(row.psSteps) + " steps" +
                           (paired ? " (paired method + " + std::to_string(levels) + ")" : "");
    const std::string captions[3] = {"input\n" + faces(panels[0]), ps + "\n" + faces(panels[1]),
                                     "Catmull-Clark " + std::to_string(row.ccLevels) +
                                         (row.ccLevels == 1 ? " level\n" : " levels\n") + faces(panels[2])};
    Box box;
    box.extend(panels[0].positions);
    const Camera camera = frameBox(box, float(o.panelWidth) / float(o.panelHeight));
    RenderOptions ro;
    ro.width = o.panelWidth, ro.height = o.panelHeight, ro.wireframe = row.wireframe;
    Image images[3];
    for (int k = 0; k < 3; ++k) {
        Renderer renderer(context, polygonsOf(panels[k].surface), ro);
        renderer.draw(panels[k].positions, panels[k].normals, camera, images[k]);
    }
    return panelsWithCaptions(images, captions);
}

// ---------------------------------------------------------------------------------------
// Table I

struct FaceCounts {
    std::string name;
    std::vector<std::uint64_t> ps;  // per topological step 0..steps
    std::vector<std::uint64_t> cc;  // per level 0..steps/2 (at step 2 * level)
};

FaceCounts countFaces(const Model& model, int steps) {
    const Mesh& mesh = model.mesh;
    FaceCounts counts{model.row.name, {}, {}};
    const Counts input = countMesh(mesh.faces, model.checked.connectivity);
    for (int k = 0; k <= steps; ++k) counts.ps.push_back(countsAfterSteps(input, k).faces);
    for (const CatmarkLevel& level : refineCatmark(mesh.faces, {}, steps / 2, false)) counts.cc.push_back(level.counts.faces);
    return counts;
}

void printTable(const std::vector<FaceCounts>& models, int steps) {
    std::printf("Table I: faces after each step (a P-S step, the paired method counting as one, beside a\n"
                "Catmull-Clark level at every second step)\n\n| step |");
    for (const FaceCounts& m : models) std::printf(" %s P-S | %s CC |", m.name.c_str(), m.name.c_str());
    std::printf("\n| ---: |");
    for (std::size_t i = 0; i < models.size(); ++i) std::printf(" ---: | ---: |");
    std::printf("\n");
    for (int k = 0; k <= steps; ++k) {
        std::printf("| %d |", k);
        for (const FaceCounts& m : models)
            std::printf(" %s | %s |", withThousands(m.ps[std::size_t(k)]).c_str(),
                        k % 2 == 0 ? withThousands(m.cc[std::size_t(k / 2)]).c_str() : "");
        std::printf("\n");
    }
}

// A line from (x0, y0) to (x1, y1), `thickness` pixels wide.
void drawLine(Image& image, double x0, double y0, double x1, double y1, Rgba colour, int thickness = 2) {
    const int steps = int(std::max(std::abs(x1 - x0), std::abs(y1 - y0))) + 1;
    for (int i = 0; i <= steps; ++i) {
        const double t = double(i) / steps, x = x0 + t * (x1 - x0), y = y0 + t * (y1 - y0);
        for (int dy = 0; dy < thickness; ++dy)
            for (int dx = 0; dx < thickness; ++dx) {
                const int px = int(x) + dx - thickness / 2, py = int(y) + dy - thickness / 2;
                if (px >= 0 && py >= 0 && px < int(image.width) && py < int(image.height))
                    image.setPixel(std::uint32_t(px), std::uint32_t(py), colour);
            }
    }
}

void drawDot(Image& image, double x, double y, Rgba colour) { drawLine(image, x, y, x, y, colour, 7); }

// Faces per step on a log2 scale: P-S solid with a dot per step, Catmull-Clark dashed-free
// with a dot per level; one colour per model.
Image plotTable(const std::vector<FaceCounts>& models, int steps) {
    constexpr std::uint32_t width = 800, height = 480;
    constexpr double left = 90, right = 270, top = 50, bottom = 60;
    Image image = filledImage(width, height, {255, 255, 255, 255});
    const Rgba ink{30, 30, 30, 255}, grid{225, 225, 225, 255};
    const Rgba colours[][2] = {{{214, 96, 40, 255}, {240, 170, 120, 255}}, {{40, 110, 190, 255}, {130, 180, 230, 255}}};
    double lo = 1e300, hi = 0;
    for (const FaceCounts& m : models)
        for (std::uint64_t f : m.ps) lo = std::min(lo, double(f)), hi = std::max(hi, double(f));
    const int low = int(std::floor(std::log2(lo))), high = int(std::ceil(std::log2(hi)));
    const auto px = [&](double step) { return left + step / steps * (width - left - right); };
    const auto py = [&](double faces) {
        return height - bottom - (std::log2(faces) - low) / (high - low) * (height - top - bottom);
    };
    for (int e = low; e <= high; e += 2) {
        drawLine(image, left, py(std::ldexp(1.0, e)), width - right, py(std::ldexp(1.0, e)), grid, 1);
        const std::string label = "2^" + std::to_string(e);
        drawText(image, int(left) - 10 - textSize(label, 2)[0], int(py(std::ldexp(1.0, e))) - 6, label, 2, ink);
    }
    for (int k = 0; k <= steps; ++k) {
        drawLine(image, px(k), top, px(k), height - bottom, grid, 1);
        drawText(image, int(px(k)) - 4, int(height - bottom) + 8, std::to_string(k), 2, ink);
    }
    drawText(image, int(left), int(height) - 26, "step (P-S; Catmull-Clark level = step / 2)", 2, ink);
    drawText(image, int(left), 14, "Table I: faces per step, log scale", 2, ink);
    for (std::size_t i = 0; i < models.size(); ++i) {
        const FaceCounts& m = models[i];
        const Rgba ps = colours[i % 2][0], cc = colours[i % 2][1];
        for (int k = 0; k <= steps; ++k) {
            if (k) drawLine(image, px(k - 1), py(double(m.ps[std::size_t(k - 1)])), px(k), py(double(m.ps[std::size_t(k)])), ps);
            drawDot(image, px(k), py(double(m.ps[std::size_t(k)])), ps);
        }
        for (std::size_t l = 0; l < m.cc.size(); ++l) {
            if (l) drawLine(image, px(2.0 * double(l - 1)), py(double(m.cc[l - 1])), px(2.0 * double(l)), py(double(m.cc[l])), cc, 1);
            drawDot(image, px(2.0 * double(l)) + 4, py(double(m.cc[l])), cc);
        }
        const int legendY = int(top) + 20 + int(i) * 50;
        drawDot(image, width - right + 20, legendY + 6, ps);
        drawText(image, int(width - right) + 32, legendY, m.name + " P-S", 2, ink);
        drawDot(image, width - right + 20, legendY + 28, cc);
        drawText(image, int(width - right) + 32, legendY + 22, m.name + " Catmull-Clark", 2, ink);
    }
    return image;
}

}  // namespace

CLI::App* addFigure5Command(CLI::App& app, Figure5Options& o) {
    CLI::App* fi = app.add_subcommand(
        "figure5", "Rebuild the paper's Figure 5 (P-S beside Catmull-Clark at equal face counts) and Table I");
    fi->add_option("-o,--output-dir", o.outputDir, "directory for figure5_cow.png, figure5_cube.png and table1.png")
        ->default_val(".");
    addSize(fi, "--panel-size", o.panelWidth, o.panelHeight, "size of each picture in a row", 64, "480x360");
    fi->footer("Rows: the bundled cow (input; P-S 2 steps, the paired method being the first; Catmull-Clark 1\n"
               "level) and cube (input; P-S 4 steps; Catmull-Clark 2 levels). Each row uses one camera, framing\n"
               "the input, so the shrinking of P-S shows. Drawn offscreen with Vulkan (lavapipe will do).\n"
               "Example:\n  psub figure5 -o docs/");
    return fi;
}

CLI::App* addFigureShapeCommand(CLI::App& app, Figure5Options& o) {
    CLI::App* fs = app.add_subcommand(
        "figure-shape", "The cube after 4 P-S steps with the paper's and the shape rules beside Catmull-Clark's 2 levels");
    fs->add_option("-o,--output-dir", o.outputDir, "directory for figure_shape_cube.png")->default_val(".");
    addSize(fs, "--panel-size", o.panelWidth, o.panelHeight, "size of each picture in the row", 64, "480x360");
    fs->footer("One row, one camera framing the input cube, all three at 96 faces: P-S 4 steps with --rules\n"
               "paper, P-S 4 steps with --rules shape, Catmull-Clark (OpenSubdiv) 2 levels. Drawn offscreen\n"
               "with Vulkan (lavapipe will do).\n"
               "Example:\n  psub figure-shape -o docs/ --panel-size 400x300");
    return fs;
}

int runFigureShape(const Figure5Options& o) {
    makeOutputDirectory(o.outputDir);
    Model model{{"cube", 4, 2, Wireframe::Refined}, {}, {}};
    model.mesh = loadChecked(dataDir() + "/cube.obj", model.checked);
    const std::string out = (std::filesystem::path(o.outputDir) / "figure_shape_cube.png").string();
    try {
        VulkanContext context;
        const Mesh& mesh = model.mesh;
        const Drawable panels[3] = {drawablePS(context, Backend::Cpu, mesh, model.checked, 4, Rules::Paper),
                                    drawablePS(context, Backend::Cpu, mesh, model.checked, 4, Rules::Shape),
                                    drawableCC(context, Backend::Cpu, mesh, 2)};
        const std::string captions[3] = {"P-S 4 steps, --rules paper\n" + faces(panels[0]),
                                         "P-S 4 steps, --rules shape\n" + faces(panels[1]),
                                         "Catmull-Clark 2 levels\n" + faces(panels[2])};
        Box box;
        box.extend(std::vector<float>(mesh.positions.begin(), mesh.positions.end()));
        const Camera camera = frameBox(box, float(o.panelWidth) / float(o.panelHeight));
        RenderOptions ro;
        ro.width = o.panelWidth, ro.height = o.panelHeight, ro.wireframe = Wireframe::Refined;
        Image images[3];
        for (int k = 0; k < 3; ++k) {
            Renderer renderer(context, polygonsOf(panels[k].surface), ro);
            renderer.draw(panels[k].positions, panels[k].normals, camera, images[k]);
        }
        writeOutput(out, encodePng(out, panelsWithCaptions(images, captions)));
    } catch (const VulkanError& e) {
        std::fprintf(stderr, "psub: error: figure-shape: %s\n", e.what());
        return 1;
    } catch (const std::runtime_error& e) {  // the PNG could not be written
        if (dynamic_cast<const InputError*>(&e)) throw;
        std::fprintf(stderr, "psub: error: figure-shape: %s\n", e.what());
        return 1;
    }
    std::printf("%s\n", out.c_str());
    return 0;
}

int runFigure5(const Figure5Options& o) {
    const std::string data = dataDir();
    makeOutputDirectory(o.outputDir);  // before the drawing, so a bad -o fails at once
    std::vector<Model> models;
    std::vector<FaceCounts> counts;
    for (const Row& row : kRows) {
        Model& model = models.emplace_back(Model{row, {}, {}});
        model.mesh = loadChecked(data + "/" + row.name + ".obj", model.checked);
        counts.push_back(countFaces(model, 8));
    }
    // Every picture is drawn and encoded first, then all are written as one (psub::writeOutputs):
    // a failure leaves none of them.
    std::vector<OutputFile> files;
    const auto pathOf = [&](const std::string& name) { return (std::filesystem::path(o.outputDir) / name).string(); };
    try {
        VulkanContext context;
        for (const Model& model : models) {
            const std::string out = pathOf("figure5_" + std::string(model.row.name) + ".png");
            files.emplace_back(out, encodePng(out, drawRow(context, model, o)));
        }
        const std::string table = pathOf("table1.png");
        files.emplace_back(table, encodePng(table, plotTable(counts, 8)));
        writeOutputs(files);
        for (const OutputFile& file : files) std::printf("%s\n", file.first.c_str());
        std::printf("\n");
    } catch (const VulkanError& e) {
        std::fprintf(stderr, "psub: error: figure5: %s\n", e.what());
        return 1;
    } catch (const std::runtime_error& e) {  // a PNG could not be written
        if (dynamic_cast<const InputError*>(&e)) throw;
        std::fprintf(stderr, "psub: error: figure5: %s\n", e.what());
        return 1;
    }
    printTable(counts, 8);
    return 0;
}

}  // namespace psub::cli
