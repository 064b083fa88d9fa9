// The procedural deformers of psub/animation.h (wave, twist, bend): the formulas documented
// there, applied per vertex in double, with no allocation; large meshes on all cores (each
// vertex on its own, so the results do not depend on the threads).
#include "psub/animation.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace psub {
namespace {

// Meshes with more values than this are deformed on all cores (a parallel region costs a few
// microseconds; a vertex about 10 ns).
constexpr std::size_t kParallelValues = 3 * 16384;

// Axes in tie-breaking order: on equal extents y wins, then x, then z.
constexpr std::array<int, 3> kAxisPriority = {1, 0, 2};

// What the deformers need from the box, derived once per call.
struct Frame {
    std::array<double, 3> min{}, centre{}, extent{};
    double size = 1;  // L
    int longest = 1, shortest = 1;
};

Frame frameOf(const RestBounds& bounds) {
    Frame frame;
    for (int axis = 0; axis < 3; ++axis) {
        frame.min[axis] = bounds.min[axis];
        frame.centre[axis] = 0.5 * (bounds.min[axis] + bounds.max[axis]);
        frame.extent[axis] = bounds.max[axis] - bounds.min[axis];
    }
    for (int axis : kAxisPriority) {
        if (frame.extent[axis] > frame.extent[frame.longest]) frame.longest = axis;
        if (frame.extent[axis] < frame.extent[frame.shortest]) frame.shortest = axis;
    }
    frame.size = frame.extent[frame.longest] > 0 ? frame.extent[frame.longest] : 1.0;
    return frame;
}

// The longest axis other than `excluded`, ties broken by kAxisPriority.
int longestOther(const Frame& frame, int excluded) {
    int best = -1;
    for (int axis : kAxisPriority)
        if (axis != excluded && (best < 0 || frame.extent[axis] > frame.extent[best])) best = axis;
    return best;
}

double phaseAt(double seconds) {
    const double cycles = std::fmod(seconds, kProceduralPeriod) / kProceduralPeriod;
    return 2 * std::numbers::pi * cycles;
}

void wave(const Frame& frame, std::span<const float> rest, double seconds, std::span<float> out) {
    const int up = frame.shortest;
    const int travel = longestOther(frame, up);
    const double amplitude = kWaveAmplitude * frame.size;
    const double waveNumber = 2 * std::numbers::pi / (frame.size / 2);
    const double phase = phaseAt(seconds);
#pragma omp parallel for schedule(static) if (rest.size() > kParallelValues)
    for (std::size_t i = 0; i < rest.size(); i += 3) {
        const double along = double(rest[i + travel]) - frame.min[travel];
        std::copy_n(&rest[i], 3, &out[i]);
        out[i + up] = float(double(rest[i + up]) + amplitude * std::sin(waveNumber * along - phase));
    }
}

void twist(const Frame& frame, std::span<const float> rest, double seconds, std::span<float> out) {
    const int axis = frame.longest, first = (axis + 1) % 3, second = (axis + 2) % 3;
    const double anglePerLength = kTwistAngle * std::sin(phaseAt(seconds)) / frame.size;
#pragma omp parallel for schedule(static) if (rest.size() > kParallelValues)
    for (std::size_t i = 0; i < rest.size(); i += 3) {
        const double theta = anglePerLength * (double(rest[i + axis]) - frame.centre[axis]);
        const double q1 = double(rest[i + first]) - frame.centre[first];
        const double q2 = double(rest[i + second]) - frame.centre[second];
        const double cosine = std::cos(theta), sine = std::sin(theta);
        out[i + axis] = rest[i + axis];
        out[i + first] = float(frame.centre[first] + cosine * q1 - sine * q2);
        out[i + second] = float(frame.centre[second] + sine * q1 + cosine * q2);
    }
}

void bend(const Frame& frame, std::span<const float> rest, double seconds, std::span<float> out) {
    const int axis = frame.longest, towards = longestOther(frame, axis);
    const double curvature = kBendAngle * std::sin(phaseAt(seconds)) / frame.size;
    if (curvature == 0) {
        std::copy(rest.begin(), rest.end(), out.begin());
        return;
    }
#pragma omp parallel for schedule(static) if (rest.size() > kParallelValues)
    for (std::size_t i = 0; i < rest.size(); i += 3) {
        const double along = double(rest[i + axis]) - frame.centre[axis];
        const double offset = double(rest[i + towards]) - frame.centre[towards];
        const double phi = curvature * along;
        const double sine = std::sin(phi), cosine = std::cos(phi);
        const double halfSine = std::sin(phi / 2);  // 1 - cos(phi) = 2 sin^2(phi / 2), no cancellation
        std::copy_n(&rest[i], 3, &out[i]);
        out[i + axis] = float(frame.centre[axis] + sine / curvature - offset * sine);
        out[i + towards] =
            float(frame.centre[towards] + 2 * halfSine * halfSine / curvature + offset * cosine);
    }
}

}  // namespace

std::optional<Procedural> parseProcedural(std::string_view name) {
    for (Procedural kind : {Procedural::Wave, Procedural::Twist, Procedural::Bend})
        if (name == proceduralName(kind)) return kind;
    return std::nullopt;
}

std::string_view proceduralName(Procedural kind) {
    switch (kind) {
        case Procedural::Wave: return "wave";
        case Procedural::Twist: return "twist";
        case Procedural::Bend: return "bend";
    }
    return "?";
}

RestBounds restBounds(std::span<const float> positions) {
    assert(positions.size() % 3 == 0);
    RestBounds bounds;
    if (positions.empty()) return bounds;
    for (int axis = 0; axis < 3; ++axis) bounds.min[axis] = bounds.max[axis] = positions[axis];
    for (std::size_t i = 0; i < positions.size(); i += 3)
        for (int axis = 0; axis < 3; ++axis) {
            bounds.min[axis] = std::min(bounds.min[axis], double(positions[i + axis]));
            bounds.max[axis] = std::max(bounds.max[axis], double(positions[i + axis]));
        }
    return bounds;
}

void deformProcedural(Procedural kind, const RestBounds& bounds, std::span<const float> rest,
                      double seconds, std::span<float> out) {
    assert(rest.size() % 3 == 0 && out.size() == rest.size() && std::isfinite(seconds));
    const Frame frame = frameOf(bounds);
    switch (kind) {
        case Procedural::Wave: wave(frame, rest, seconds, out); return;
        case Procedural::Twist: twist(frame, rest, seconds, out); return;
        case Procedural::Bend: bend(frame, rest, seconds, out); return;
    }
}

}  // namespace psub
