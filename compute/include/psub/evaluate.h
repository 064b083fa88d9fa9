// psub/evaluate.h: the evaluator contract every backend follows (OpenSubdiv's Osd evaluators
// are the model). A backend is built from the tables of one refinement (EvaluatorTables) and
// a TableForm, and per frame runs evaluate(control, refined, normals). The program picks a
// backend once, where it creates the evaluator, and never branches on it again.
//
// The rules, the same for every backend:
// - Tables: the evaluator may keep references to the tables it was built from; they must
//   outlive it (the Vulkan backend copies them to the device and keeps none, but callers may
//   not rely on that).
// - Data: float, 3 values (x, y, z) per vertex, packed, control points in, refined positions
//   out in the order of surface()'s vertices; normals on request (a non-empty span), unit
//   vertex normals of the refined surface, 3 per vertex. No layouts or row ranges here: those
//   are psub/evaluator.h's low-level functions (CPU only).
// - Drawing order: surface() is the face list to draw over the refined vertices: the finest
//   faces for PerLevel and Factorized (canonical order, docs/scheme.md), the tiled table's own
//   faces for Tiled (its drawing order; toCanonical in psub/evaluator.h rearranges).
// - Forms: every backend takes all three (the CPU and Vulkan ones do); a backend without one
//   throws std::invalid_argument naming itself.
// - Frames allocate nothing. Bad control points: NaN or infinite results where they reach,
//   never a crash (psub/evaluator.h).
//
// To add a backend: implement Evaluator, give it a make...Evaluator(…, EvaluatorTables,
// TableForm) factory, and run tests/evaluate_contract_test.cpp's checks on it (docs/design.md).
#pragma once

#include "psub/evaluator.h"
#include "psub/tables.h"
#include "psub/tiled.h"

#include <cstdint>
#include <memory>
#include <span>
#include <string>

namespace psub {

// The tables of one refinement an evaluator may be built from; `factorized` and `tiled` may be
// empty tables when their form is not used, `surface` when normals are never asked for.
struct EvaluatorTables {
    const PerLevelTable& perLevel;
    const FactorizedTable& factorized;
    const SurfaceTable& surface;
    const TiledTable& tiled;
};

// The tables of a psub::Refinement (psub/stencils.h), or of anything with the same members.
template <class Refinement>
EvaluatorTables tablesOf(const Refinement& r) {
    return {r.perLevel, r.factorized, r.surface, r.tiled};
}

// Host-side milliseconds of the last evaluate(): writing control points where the backend
// reads them, the stencils, the normals, copying results back (0 where a stage is not separate:
// the CPU backend's tiled form computes normals in its tile pass, counted in evaluateMs).
struct StageTimes {
    double uploadMs = 0, evaluateMs = 0, normalsMs = 0, readbackMs = 0;
};

class Evaluator {
public:
    virtual ~Evaluator() = default;

    virtual std::uint32_t controlCount() const = 0;
    virtual std::uint32_t refinedCount() const = 0;
    // The faces to draw over the refined vertices, in the order evaluate() writes them.
    virtual const SurfaceTable& surface() const = 0;
    // Where it runs, for reports: "CPU, 8 threads", a Vulkan device's name.
    virtual std::string device() const = 0;

    // One frame. control: 3 * controlCount() floats; refined: 3 * refinedCount() floats, or
    // empty when the results may stay where the backend keeps them (the Vulkan backend's device
    // buffers); normals: empty (none computed) or 3 * refinedCount() floats.
    virtual void evaluate(std::span<const float> control, std::span<float> refined,
                          std::span<float> normals = {}) = 0;
    // One frame whose results stay with the backend (nothing copied out): positions, and normals
    // when `withNormals`. For drawing from the backend's own buffers and for timing.
    virtual void evaluateKept(std::span<const float> control, bool withNormals) = 0;
    // True when the backend keeps its results in host memory anyway (copying them out into the
    // caller's spans costs no transfer): a caller that may want them asks for them every frame.
    virtual bool resultsOnHost() const = 0;
    virtual StageTimes lastTimes() const = 0;
};

// The CPU backend (CpuEvaluator<float> on `threads` threads, 0: all cores).
std::unique_ptr<Evaluator> makeCpuEvaluator(const EvaluatorTables& tables, TableForm form, int threads = 0);

}  // namespace psub
