// Eigen-analysis of the local subdivision matrices: leading eigenvalues and the necessary C1
// conditions, the characteristic map, the tangent-plane check, Catmull-Clark's lambda1.
#include "local_detail.h"

#include "psub/analysis.h"

#include <Eigen/Dense>

#include <cmath>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

namespace psub {
namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Complex = std::complex<double>;

using MatrixView = Eigen::Map<const RowMajor>;

// The matrix in place, without a copy (the whole matrix can be large at high valence).
MatrixView view(const LocalMatrix& m) {
    const Eigen::Index size = Eigen::Index(m.size());
    return MatrixView(m.weights.data(), size, size);
}

// Indices of `values` in descending modulus (ties: real part, then imaginary part, larger first).
std::vector<std::size_t> descendingOrder(const Eigen::VectorXcd& values) {
    std::vector<std::size_t> order(std::size_t(values.size()));
    std::iota(order.begin(), order.end(), std::size_t(0));
    const auto key = [&](std::size_t k) {
        const Complex v = values[Eigen::Index(k)];
        return std::tuple(std::llround(std::abs(v) * 1e10), v.real(), v.imag());
    };
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return key(a) > key(b); });
    return order;
}

// The keys of ring k in order around the centre: per sector (k, 0) .. (k, k) .. (1, k).
std::vector<GridKey> ringWalk(int n, int k) {
    std::vector<GridKey> walk;
    for (int s = 0; s < n; ++s) {
        for (int j = 0; j <= k; ++j) walk.push_back(detail::canonical(s, k, j, n));
        for (int i = k - 1; i >= 1; --i) walk.push_back(detail::canonical(s, i, k, n));
    }
    return walk;
}

// Turns of the closed polygon `points` around the origin; 0 when it passes through it.
int windingNumber(const std::vector<std::array<double, 2>>& points) {
    double total = 0;
    for (std::size_t a = 0; a < points.size(); ++a) {
        const auto& p = points[a];
        const auto& q = points[(a + 1) % points.size()];
        if ((p[0] == 0 && p[1] == 0) || (q[0] == 0 && q[1] == 0)) return 0;
        total += std::atan2(p[0] * q[1] - p[1] * q[0], p[0] * q[0] + p[1] * q[1]);
    }
    return int(std::lround(total / (2 * std::numbers::pi)));
}

// The corners of the quad (s, i..i+1, j..j+1) as matrix indices.
std::array<std::size_t, 4> quadCorners(const std::unordered_map<std::uint64_t, std::size_t>& indexOf, int n,
                                       int s, int i, int j) {
    return {indexOf.at(detail::packKey(detail::canonical(s, i, j, n))),
            indexOf.at(detail::packKey(detail::canonical(s, i + 1, j, n))),
            indexOf.at(detail::packKey(detail::canonical(s, i + 1, j + 1, n))),
            indexOf.at(detail::packKey(detail::canonical(s, i, j + 1, n)))};
}

// Extends eigenvectors `v` (columns) of the matrix's 3-ring block with eigenvalue mu to all of
// `whole`, ring by ring: every neighbourhood of 3 or more rings is invariant, so the matrix is
// block lower triangular by ring from ring 4 on, and ring k solves
// (mu I - S_kk) w_k = S_k,<k w_<k.
template <class Scalar>
Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> extendByRings(const MatrixView& whole,
                                                                     const std::vector<Eigen::Index>& ringBegin, Scalar mu,
                                                                     const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& v) {
    using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
    Matrix full(whole.rows(), v.cols());
    full.topRows(v.rows()) = v;
    for (std::size_t k = 4; k + 1 < ringBegin.size(); ++k) {
        const Eigen::Index begin = ringBegin[k], size = ringBegin[k + 1] - begin;
        const Matrix block = mu * Matrix::Identity(size, size) - whole.block(begin, begin, size, size).template cast<Scalar>();
        full.middleRows(begin, size) =
            block.partialPivLu().solve(whole.block(begin, 0, size, begin).template cast<Scalar>() * full.topRows(begin));
    }
    return full;
}

// The subdominant pair of the 3-ring block (rows and columns 0..ringBegin[4]) as two real
// coordinate vectors over all of `whole`: the characteristic map's control net.
struct PlanarMap {
    Eigen::VectorXd x, y;
};

PlanarMap characteristicMap(const MatrixView& whole, const std::vector<Eigen::Index>& ringBegin,
                            const Eigen::EigenSolver<Eigen::MatrixXd>& solver, std::size_t first, std::size_t second,
                            bool realEqualPair) {
    const Eigen::Index innerSize = ringBegin[4];
    const Complex mu1 = solver.eigenvalues()[Eigen::Index(first)], mu2 = solver.eigenvalues()[Eigen::Index(second)];
    PlanarMap map;
    if (realEqualPair) {
        // The eigenspace of the double eigenvalue: the two right singular vectors of
        // S - mu I with the smallest singular values.
        const double mu = (mu1.real() + mu2.real()) / 2;
        const Eigen::MatrixXd inner = whole.topLeftCorner(innerSize, innerSize);
        const Eigen::BDCSVD<Eigen::MatrixXd> svd(inner - mu * Eigen::MatrixXd::Identity(innerSize, innerSize),
                                                 Eigen::ComputeFullV);
        const Eigen::MatrixXd full = extendByRings<double>(whole, ringBegin, mu, svd.matrixV().rightCols(2));
        map.x = full.col(0);
        map.y = full.col(1);
    } else if (mu1.imag() != 0 && std::abs(mu1 - std::conj(mu2)) <= 1e-9 * std::abs(mu1)) {
        // A complex pair: the real and imaginary parts of one eigenvector span the invariant plane.
        const Eigen::MatrixXcd full = extendByRings<Complex>(whole, ringBegin, mu1, solver.eigenvectors().col(Eigen::Index(first)));
        map.x = full.col(0).real();
        map.y = full.col(0).imag();
    } else {
        map.x = extendByRings<double>(whole, ringBegin, mu1.real(), solver.eigenvectors().col(Eigen::Index(first)).real()).col(0);
        map.y = extendByRings<double>(whole, ringBegin, mu2.real(), solver.eigenvectors().col(Eigen::Index(second)).real()).col(0);
    }
    return map;
}

// Largest angle (degrees) between the normals of two of `faces` (corner indices into rows of p).
double normalSpread(const Eigen::MatrixXd& p, const std::vector<std::array<std::size_t, 4>>& faces) {
    std::vector<Eigen::Vector3d> normals;
    for (const auto& f : faces) {
        const Eigen::Vector3d d0 = p.row(Eigen::Index(f[2])) - p.row(Eigen::Index(f[0]));
        const Eigen::Vector3d d1 = p.row(Eigen::Index(f[3])) - p.row(Eigen::Index(f[1]));
        const Eigen::Vector3d normal = d0.cross(d1);
        if (normal.norm() == 0) return 180;  // a face without area has no normal
        normals.push_back(normal.normalized());
    }
    double lowest = 1;
    for (std::size_t a = 0; a < normals.size(); ++a)
        for (std::size_t b = a + 1; b < normals.size(); ++b) lowest = std::min(lowest, normals[a].dot(normals[b]));
    return std::acos(std::clamp(lowest, -1.0, 1.0)) * 180 / std::numbers::pi;
}

}  // namespace

std::vector<std::complex<double>> eigenvalues(const LocalMatrix& matrix) {
    const Eigen::EigenSolver<Eigen::MatrixXd> solver(Eigen::MatrixXd(view(matrix)), false);
    std::vector<Complex> out;
    for (std::size_t k : descendingOrder(solver.eigenvalues())) out.push_back(solver.eigenvalues()[Eigen::Index(k)]);
    return out;
}

ValenceReport analyzeValence(Index valence, Rules rules, const ValenceOptions& options) {
    if (valence < 2 || options.characteristicRings < 4 || options.tangentLevels < 1)
        throw std::invalid_argument("analyzeValence: valence >= 2, characteristicRings >= 4, tangentLevels >= 1");
    const int n = int(valence), rings = options.characteristicRings;
    const double tol = options.tolerance;
    ValenceReport report;
    report.valence = valence;
    report.rules = rules;

    // The whole matrix on `rings` rings; its 3-ring block is the 3-ring matrix (rows of ring
    // <= 3 never reach further out: the neighbourhood is invariant).
    if (options.extendedRule && options.extendedRule->valence != valence)
        throw std::invalid_argument("analyzeValence: the extended rule is for another valence");
    const LocalMatrix whole = options.extendedRule   ? psTwoStepMatrix(*options.extendedRule, rings)
                              : options.centreWeights ? psTwoStepMatrix(valence, *options.centreWeights, rings)
                                                      : psTwoStepMatrix(valence, rules, rings);
    const MatrixView matrix = view(whole);
    std::vector<Eigen::Index> ringBegin{0, 1};  // rows of ring k: ringBegin[k] .. ringBegin[k+1]
    for (int k = 1; k <= rings; ++k) ringBegin.push_back(ringBegin.back() + 2 * k * n);
    for (int k = 3; k < rings; ++k)
        if (matrix.topRightCorner(ringBegin[std::size_t(k) + 1], matrix.cols() - ringBegin[std::size_t(k) + 1]).cwiseAbs().maxCoeff() > 0)
            throw std::logic_error("analyzeValence: a neighbourhood of 3 or more rings is not invariant");
    const Eigen::Index innerSize = ringBegin[4];
    report.matrixSize = std::size_t(innerSize);
    const Eigen::EigenSolver<Eigen::MatrixXd> solver(Eigen::MatrixXd(matrix.topLeftCorner(innerSize, innerSize)), true);
    const std::vector<std::size_t> order = descendingOrder(solver.eigenvalues());
    const auto lambda = [&](std::size_t k) { return solver.eigenvalues()[Eigen::Index(order[k])]; };
    for (std::size_t k = 0; k < std::min<std::size_t>(6, order.size()); ++k) report.eigenvalues.push_back(lambda(k));

    const Complex l0 = lambda(0), l1 = lambda(1), l2 = lambda(2), l3 = lambda(3);
    const auto isReal = [&](Complex v) { return std::abs(v.imag()) <= tol * std::max(1.0, std::abs(v)); };
    const bool realEqualPair = isReal(l1) && isReal(l2) && std::abs(l1.real() - l2.real()) <= tol * std::max(1.0, std::abs(l1));
    report.lambda1 = l1.real();
    report.lambda3OverLambda1Squared = std::abs(l3) / (l1.real() * l1.real());
    report.spectralGap = l1.real() - std::abs(l3);
    report.c1Necessary = std::abs(l0 - 1.0) <= tol && realEqualPair && l1.real() > 0 &&
                         l1.real() < 1 - tol && l1.real() > std::abs(l3) + tol;

    // Characteristic map: the control net of the subdominant pair, ring windings, face signs.
    const PlanarMap map = characteristicMap(matrix, ringBegin, solver, order[1], order[2], realEqualPair);
    std::unordered_map<std::uint64_t, std::size_t> indexOf;
    for (std::size_t k = 0; k < whole.size(); ++k) indexOf[detail::packKey(whole.keys[k])] = k;
    for (int k = 1; k <= rings; ++k) {
        std::vector<std::array<double, 2>> points;
        for (const GridKey& key : ringWalk(n, k)) {
            const auto at = Eigen::Index(indexOf.at(detail::packKey(key)));
            points.push_back({map.x[at], map.y[at]});
        }
        report.ringWindings.push_back(windingNumber(points));
    }
    const int turn = report.ringWindings.front();
    bool windsOnce = turn == 1 || turn == -1;
    for (int w : report.ringWindings) windsOnce = windsOnce && w == turn;
    for (int s = 0; s < n; ++s)
        for (int i = 0; i < rings; ++i)
            for (int j = 0; j < rings; ++j) {
                const auto c = quadCorners(indexOf, n, s, i, j);
                double area = 0;
                for (int a = 0; a < 4; ++a) {
                    const auto p = Eigen::Index(c[std::size_t(a)]), q = Eigen::Index(c[std::size_t((a + 1) % 4)]);
                    area += map.x[p] * map.y[q] - map.x[q] * map.y[p];
                }
                const bool folded = area * turn <= 0;
                report.foldedFaces += folded;
                if (2 * (std::max(i, j) + 1) > rings) {
                    ++report.annulusFaces;
                    report.foldedAnnulusFaces += folded;
                }
            }
    report.characteristicMapInjective = windsOnce && report.foldedAnnulusFaces == 0;

    // Tangent plane: a bumpy neighbourhood, two steps at a time, cropped to 3 rings.
    const LocalMesh bumpy = makeLocalMesh(valence, 3, 1.0);
    Eigen::MatrixXd points(innerSize, 3);
    for (Index v = 0; v < bumpy.mesh.faces.vertexCount; ++v) {
        const auto at = Eigen::Index(indexOf.at(detail::packKey(bumpy.keys[v])));
        for (int axis = 0; axis < 3; ++axis) points(at, axis) = bumpy.mesh.positions[3 * v + std::size_t(axis)];
    }
    std::vector<std::array<std::size_t, 4>> nearFaces;
    for (int s = 0; s < n; ++s)
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j) nearFaces.push_back(quadCorners(indexOf, n, s, i, j));
    const Eigen::MatrixXd step = matrix.topLeftCorner(innerSize, innerSize);
    for (int level = 0; level <= options.tangentLevels; ++level) {
        report.normalSpreadDegrees.push_back(normalSpread(points, nearFaces));
        points = step * points;
    }

    // Catmull-Clark at the same valence.
    report.ccLambda1 = eigenvalues(catmarkOneStepMatrix(valence, 1))[1].real();
    report.ccLambda1ClosedForm = catmarkSubdominantClosedForm(valence);
    return report;
}

}  // namespace psub
