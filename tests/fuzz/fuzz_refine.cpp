// libFuzzer target: whatever parses and passes the checks is preprocessed, refined two
// levels (either boundary mode), turned into all three table forms (the per-level rows and the
// tiled form's as refine() leaves them: regular vertex rows read face points) and evaluated (the tiled
// one, a tile on every regular block, also with its normals in the tile pass); the counts must
// match the closed form and the table forms must agree (the tiled one once put back in
// canonical order); the tiled form's lean build (no per-level table) must make the same table;
// so must its drawing-only build (no canonical order) but for what it leaves out; the per-level
// table ordered by region (2 or 3 regions) must give the same bits; the tiled
// form without a tile (TileSides::None, lean) has none and agrees too; within the numeric-range
// policy the values are finite.
#include "psub/evaluator.h"
#include "psub/stencils.h"

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        const psub::Mesh mesh = psub::parseObj(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.obj");
        if (mesh.faces.verts.size() > 20000) return 0;  // keep each input fast
        const psub::CheckedMesh checked = psub::checkMesh(mesh);
        psub::RefineOptions options{2, psub::Preprocess::Auto, true, {}};
        options.tiled = true;
        options.tileSides = psub::TileSides::Every;  // small inputs: tiles wherever a block is regular
        options.boundary = size % 2 ? psub::Boundary::Smooth : psub::Boundary::Paper;  // both, by input length
        const psub::Refinement r = psub::refine(mesh, checked.connectivity, options);
        const psub::Counts expected = psub::countsAfterSteps(psub::countMesh(mesh.faces, checked.connectivity),
                                                             r.preprocessed ? 3 : 2, options.boundary, r.preprocessed);
        if (r.perLevel.refinedCount() != expected.vertices || r.surface.faceOffsets.size() - 1 != expected.faces)
            std::abort();
        {
            psub::RefineOptions leanOptions = options;
            leanOptions.factorized = false;
            leanOptions.perLevel = false;
            const psub::TiledTable lean = psub::refine(mesh, checked.connectivity, leanOptions).tiled;
            if (lean.rows.destinations != r.tiled.rows.destinations || lean.rows.indices != r.tiled.rows.indices ||
                lean.rows.levels.size() != r.tiled.rows.levels.size() || lean.canonical != r.tiled.canonical ||
                lean.gather != r.tiled.gather || lean.border != r.tiled.border ||
                lean.surface.faceVerts != r.tiled.surface.faceVerts || lean.fallbackBegin != r.tiled.fallbackBegin)
                std::abort();
            // Without the canonical order: the same tiles and drawing positions; where it skipped
            // the order (tiles cover the mesh) the same positions, else the lean table itself.
            leanOptions.canonicalOrder = false;
            const psub::TiledTable drawn = psub::refine(mesh, checked.connectivity, leanOptions).tiled;
            if (drawn.gather != lean.gather || drawn.border != lean.border || drawn.output != lean.output ||
                drawn.fallbackBegin != lean.fallbackBegin || drawn.refinedCount != lean.refinedCount ||
                drawn.surface.faceOffsets != lean.surface.faceOffsets)
                std::abort();
            if (drawn.canonical.empty()) {
                if (drawn.fallbackBegin != drawn.refinedCount) std::abort();
                psub::CpuEvaluator<double> a(lean, 3, 1), b(drawn, 3, 1);
                std::vector<double> x(3 * std::size_t(lean.refinedCount)), y(x.size());
                a.evaluate(mesh.positions, x);
                b.evaluate(mesh.positions, y);
                if (x != y) std::abort();
            } else if (drawn.canonical != lean.canonical || drawn.surface.faceVerts != lean.surface.faceVerts) {
                std::abort();
            }
        }
        psub::RefineOptions noTilesOptions = options;
        noTilesOptions.factorized = false;
        noTilesOptions.perLevel = false;
        noTilesOptions.tileSides = psub::TileSides::None;
        const psub::TiledTable noTiles = psub::refine(mesh, checked.connectivity, noTilesOptions).tiled;
        if (noTiles.tileCount() != 0 || noTiles.fallbackBegin != 0 || noTiles.refinedCount != r.tiled.refinedCount)
            std::abort();
        psub::CpuEvaluator<double> perLevel(r.perLevel, r.factorized, r.surface, psub::TableForm::PerLevel, 3, 1);
        psub::CpuEvaluator<double> factorized(r.perLevel, r.factorized, r.surface, psub::TableForm::Factorized, 3, 1);
        psub::CpuEvaluator<double> tiled(r.tiled, 3, 1);
        if (tiled.refinedCount() != perLevel.refinedCount()) std::abort();
        std::vector<double> a(3 * std::size_t(perLevel.refinedCount())), b(a.size()), normals(a.size());
        std::vector<double> drawing(a.size()), c(a.size());
        perLevel.evaluate(mesh.positions, a);
        factorized.evaluate(mesh.positions, b);
        tiled.evaluate(mesh.positions, drawing);
        psub::toCanonical<double>(r.tiled, drawing, c, 3);
        tiled.normals(drawing, normals);
        std::vector<double> fused(a.size());  // positions and normals in one pass: the same positions
        tiled.evaluate(mesh.positions, fused, normals);
        for (std::size_t i = 0; i < fused.size(); ++i)
            if (std::bit_cast<std::uint64_t>(fused[i]) != std::bit_cast<std::uint64_t>(drawing[i])) std::abort();
        {
            psub::PerLevelTable regions = r.perLevel;
            psub::orderLevelsByRegion(regions, 2 + std::uint32_t(size % 3 == 0));
            psub::CpuEvaluator<double> ordered(regions, r.factorized, r.surface, psub::TableForm::PerLevel, 3, 1);
            ordered.evaluate(mesh.positions, c);
            for (std::size_t i = 0; i < c.size(); ++i)
                if (std::bit_cast<std::uint64_t>(c[i]) != std::bit_cast<std::uint64_t>(a[i])) std::abort();
            psub::toCanonical<double>(r.tiled, drawing, c, 3);
        }
        std::vector<double> untiled(a.size());
        {
            psub::CpuEvaluator<double> noTilesEvaluator(noTiles, 3, 1);
            noTilesEvaluator.evaluate(mesh.positions, drawing);
            psub::toCanonical<double>(noTiles, drawing, untiled, 3);
        }
        perLevel.normals(a, normals);
        double scale = 1;
        for (double p : mesh.positions) scale = std::max(scale, std::abs(p));
        for (std::size_t i = 0; i < a.size(); ++i)
            if ((std::isfinite(a[i]) && std::isfinite(b[i]) && std::abs(a[i] - b[i]) > 1e-4 * scale) ||
                (std::isfinite(a[i]) && std::isfinite(c[i]) && std::abs(a[i] - c[i]) > 1e-9 * scale) ||
                (std::isfinite(a[i]) && std::isfinite(untiled[i]) && std::abs(a[i] - untiled[i]) > 1e-9 * scale))
                std::abort();
        // The numeric-range policy: within the double limit, two steps stay finite in every form.
        psub::checkCoordinateRange(mesh, psub::Precision::Double);
        for (std::size_t i = 0; i < a.size(); ++i)
            if (!std::isfinite(a[i]) || !std::isfinite(b[i]) || !std::isfinite(c[i])) std::abort();
    } catch (const psub::InputError&) {
    }
    return 0;
}
