// The threaded CPU evaluator: one OpenMP parallel region per frame, rows split evenly across
// threads, a barrier between levels; normals gathered per vertex.
#include "psub/evaluator.h"

#include <omp.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <stdexcept>

namespace psub {
namespace {

// This thread's share [begin, end) of `rows` rows.
std::pair<std::uint64_t, std::uint64_t> share(std::uint64_t rows) {
    const std::uint64_t t = std::uint64_t(omp_get_thread_num()), n = std::uint64_t(omp_get_num_threads());
    return {rows * t / n, rows * (t + 1) / n};
}

// This thread's share of a level's rows, balanced by work (source indices plus the write)
// rather than by row count: a level's face rows are far cheaper than its vertex rows.
std::pair<std::uint64_t, std::uint64_t> shareByWork(const PerLevelTable& table, const StencilLevel& level) {
    const std::uint64_t t = std::uint64_t(omp_get_thread_num()), n = std::uint64_t(omp_get_num_threads());
    if (n == 1) return {0, level.rowEnd - level.rowBegin};
    std::uint64_t total = 0;
    for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g)
        total += table.groups[g].rowCount * (table.groups[g].width + 2);
    // The row at which cumulative work reaches `target`.
    auto rowAt = [&](std::uint64_t target) {
        std::uint64_t work = 0;
        for (std::uint64_t g = level.groupBegin; g < level.groupEnd; ++g) {
            const RowGroup& group = table.groups[g];
            const std::uint64_t cost = group.width + 2, groupWork = group.rowCount * cost;
            if (work + groupWork >= target)
                return group.rowBegin - level.rowBegin + (target - work + cost - 1) / cost;
            work += groupWork;
        }
        return level.rowEnd - level.rowBegin;
    };
    return {t == 0 ? 0 : rowAt(total * t / n), t + 1 == n ? level.rowEnd - level.rowBegin : rowAt(total * (t + 1) / n)};
}

// Threads worth starting for `values` output values: a parallel region and its barriers cost
// microseconds (milliseconds when the machine is oversubscribed), so small meshes run on one.
int teamFor(std::uint64_t values, int threads) {
    constexpr std::uint64_t kValuesPerThread = 32768;
    return int(std::clamp<std::uint64_t>(values / kValuesPerThread, 1, std::uint64_t(std::max(threads, 1))));
}

}  // namespace

template <class T>
CpuEvaluator<T>::CpuEvaluator(const PerLevelTable& perLevel, const FactorizedTable& factorized,
                              const SurfaceTable& surface, TableForm form, std::uint32_t width,
                              int threads)
    : perLevel_(perLevel), factorized_(factorized), surface_(surface), form_(form), width_(width),
      threads_(threads > 0 ? threads : omp_get_max_threads()) {
    if (width == 0) throw std::invalid_argument("CpuEvaluator: width must be at least 1");
    if (form == TableForm::Factorized &&
        (factorized.rowCount() != perLevel.refinedCount() || factorized.controlCount != perLevel.controlCount))
        throw std::invalid_argument("CpuEvaluator: the factorized table was not built for these levels");
    std::uint64_t total = 0;
    for (std::size_t k = 0; k + 1 < perLevel.levels.size(); ++k) {
        levelBase_.push_back(total);
        total += std::uint64_t(perLevel.levels[k].destinationCount) * width;
    }
    if (form == TableForm::PerLevel) levels_.resize(total);
    faceNormals_.resize(4 * (surface.faceOffsets.size() - 1));  // padded to 4: one aligned load each
}

template <class T>
void CpuEvaluator<T>::evaluate(std::span<const T> control, std::span<T> refined) {
    assert(control.size() >= std::size_t(controlCount()) * width_);
    assert(refined.size() >= std::size_t(refinedCount()) * width_);
    const BufferLayout packed{0, width_, width_};
    const int team = teamFor(std::uint64_t(refinedCount()) * width_ * (perLevel_.levels.size() > 1 ? 2 : 1), threads_);
    if (form_ == TableForm::Factorized) {
#pragma omp parallel num_threads(team) if (team > 1)
        {
            const auto [begin, end] = share(factorized_.rowCount());
            evaluateFactorizedRows(factorized_, control.data(), packed, refined.data(), packed,
                                   std::uint32_t(begin), std::uint32_t(end));
        }
        return;
    }
    const std::size_t levels = perLevel_.levels.size();
    if (levels == 0) {
        std::copy(control.begin(), control.begin() + std::ptrdiff_t(controlCount()) * width_, refined.begin());
        return;
    }
#pragma omp parallel num_threads(team) if (team > 1)
    for (std::size_t k = 0; k < levels; ++k) {
        const T* source = k == 0 ? control.data() : levels_.data() + levelBase_[k - 1];
        T* destination = k + 1 == levels ? refined.data() : levels_.data() + levelBase_[k];
        const StencilLevel& level = perLevel_.levels[k];
        const auto [begin, end] = shareByWork(perLevel_, level);
        evaluateLevelRows(perLevel_, k, source, packed, destination, packed, begin, end);
#pragma omp barrier
    }
}

template <class T>
void CpuEvaluator<T>::normals(std::span<const T> refined, std::span<T> normals) {
    assert(width_ >= 3 && normals.size() >= 3 * std::size_t(surface_.vertexCount));
    const std::uint32_t faces = std::uint32_t(surface_.faceOffsets.size() - 1);
    const T* p = refined.data();
    const std::size_t stride = width_;
    const int team = teamFor(3 * std::uint64_t(surface_.vertexCount), threads_);
#pragma omp parallel num_threads(team) if (team > 1)
    {
        // Newell's normal of each face: twice its area along its normal. Quads (nearly every
        // face after a few steps) unrolled; the same operations in the same order either way.
        T* faceNormals = faceNormals_.data();
        const std::uint32_t* faceOffsets = surface_.faceOffsets.data();
        const std::uint32_t* faceVerts = surface_.faceVerts.data();
#pragma omp for schedule(static)
        for (std::uint32_t f = 0; f < faces; ++f) {
            T n0 = 0, n1 = 0, n2 = 0;
            const std::uint32_t begin = faceOffsets[f], end = faceOffsets[f + 1];
            auto edge = [&](const T* a, const T* b) {
                n0 += (a[1] - b[1]) * (a[2] + b[2]);
                n1 += (a[2] - b[2]) * (a[0] + b[0]);
                n2 += (a[0] - b[0]) * (a[1] + b[1]);
            };
            if (end - begin == 4) {
                const T* p0 = p + faceVerts[begin] * stride;
                const T* p1 = p + faceVerts[begin + 1] * stride;
                const T* p2 = p + faceVerts[begin + 2] * stride;
                const T* p3 = p + faceVerts[begin + 3] * stride;
                edge(p0, p1);
                edge(p1, p2);
                edge(p2, p3);
                edge(p3, p0);
            } else {
                for (std::uint32_t c = begin; c < end; ++c)
                    edge(p + faceVerts[c] * stride, p + faceVerts[c + 1 == end ? begin : c + 1] * stride);
            }
            faceNormals[4 * std::size_t(f)] = n0;
            faceNormals[4 * std::size_t(f) + 1] = n1;
            faceNormals[4 * std::size_t(f) + 2] = n2;
            faceNormals[4 * std::size_t(f) + 3] = 0;
        }
        // Each vertex gathers its faces' normals in table order, then normalises.
        const std::uint32_t* vertexOffsets = surface_.vertexOffsets.data();
        const std::uint32_t* vertexFaces = surface_.vertexFaces.data();
        T* out = normals.data();
#pragma omp for schedule(static)
        for (std::uint32_t v = 0; v < surface_.vertexCount; ++v) {
            T n[4] = {0, 0, 0, 0};
            for (std::uint32_t i = vertexOffsets[v], end = vertexOffsets[v + 1]; i < end; ++i) {
                const T* fn = faceNormals + 4 * std::size_t(vertexFaces[i]);
                for (int axis = 0; axis < 4; ++axis) n[axis] += fn[axis];
            }
            const T n0 = n[0], n1 = n[1], n2 = n[2];
            const T length = std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
            const T scale = length > 0 ? 1 / length : 0;
            out[3 * std::size_t(v)] = n0 * scale;
            out[3 * std::size_t(v) + 1] = n1 * scale;
            out[3 * std::size_t(v) + 2] = n2 * scale;
        }
    }
}

template class CpuEvaluator<float>;
template class CpuEvaluator<double>;

}  // namespace psub
