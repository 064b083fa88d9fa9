// The CPU backend of the evaluator contract (psub/evaluate.h): CpuEvaluator<float> behind the
// Evaluator interface, with the stage times the contract reports.
#include "psub/evaluate.h"

#include <chrono>
#include <stdexcept>
#include <vector>

namespace psub {

namespace {

using Clock = std::chrono::steady_clock;

double msBetween(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
}

CpuEvaluator<float> makeCpu(const EvaluatorTables& t, TableForm form, int threads) {
    if (form == TableForm::Tiled) return CpuEvaluator<float>(t.tiled, 3, threads);
    return CpuEvaluator<float>(t.perLevel, t.factorized, t.surface, form, 3, threads);
}

class CpuBackend final : public Evaluator {
public:
    CpuBackend(const EvaluatorTables& tables, TableForm form, int threads)
        : evaluator_(makeCpu(tables, form, threads)),
          surface_(form == TableForm::Tiled ? tables.tiled.surface : tables.surface),
          positions_(3 * std::size_t(evaluator_.refinedCount())),
          fusedNormals_(form == TableForm::Tiled && evaluator_.normalsInTilePass()) {}

    void evaluateKept(std::span<const float> control, bool withNormals) override {
        if (withNormals && normals_.size() != positions_.size()) normals_.resize(positions_.size());  // once
        evaluate(control, positions_, withNormals ? std::span<float>(normals_) : std::span<float>());
    }
    bool resultsOnHost() const override { return true; }

    std::uint32_t controlCount() const override { return evaluator_.controlCount(); }
    std::uint32_t refinedCount() const override { return evaluator_.refinedCount(); }
    const SurfaceTable& surface() const override { return surface_; }
    std::string device() const override { return "CPU, " + std::to_string(evaluator_.threads()) + " threads"; }
    StageTimes lastTimes() const override { return times_; }

    void evaluate(std::span<const float> control, std::span<float> refined, std::span<float> normals) override {
        if (control.size() < 3 * std::size_t(controlCount()) ||
            (!refined.empty() && refined.size() < positions_.size()) ||
            (!normals.empty() && normals.size() < positions_.size()))
            throw std::invalid_argument("Evaluator::evaluate: a span is shorter than the contract asks");
        const std::span<float> out = refined.empty() ? std::span<float>(positions_) : refined;
        const Clock::time_point start = Clock::now();
        if (fusedNormals_ && !normals.empty()) {  // one pass: the normals' time is in evaluateMs
            evaluator_.evaluate(control, out, normals);
            times_ = {0, msBetween(start, Clock::now()), 0, 0};
            return;
        }
        evaluator_.evaluate(control, out);
        const Clock::time_point evaluated = Clock::now();
        if (!normals.empty()) evaluator_.normals(out, normals);
        times_ = {0, msBetween(start, evaluated), msBetween(evaluated, Clock::now()), 0};
    }

private:
    CpuEvaluator<float> evaluator_;
    const SurfaceTable& surface_;
    std::vector<float> positions_;  // the results when the caller passes no refined span
    std::vector<float> normals_;    // evaluateKept's normals (allocated on its first use)
    bool fusedNormals_;             // normals in the tiled form's tile pass (CpuEvaluator::evaluate)
    StageTimes times_;
};

}  // namespace

std::unique_ptr<Evaluator> makeCpuEvaluator(const EvaluatorTables& tables, TableForm form, int threads) {
    return std::make_unique<CpuBackend>(tables, form, threads);
}

}  // namespace psub
