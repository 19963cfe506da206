#include "ctcal/calibrator/knot_fit.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ctcal {

namespace {

// The p + 1 non-zero B-spline basis values of degree p at x = s + u in segment s of integer knots
// (Cox-de Boor in the form of Piegl & Tiller's BasisFuns with U_j = j: left_j = u + j - 1,
// right_j = j - u); value r belongs to coefficient s + r.
void UniformBasis(int p, double u, double* N) {
  double left[8], right[8];
  N[0] = 1.0;
  for (int j = 1; j <= p; ++j) {
    left[j] = u + j - 1.0;
    right[j] = j - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      const double temp = N[r] / (right[r + 1] + left[j - r]);
      N[r] = saved + right[r + 1] * temp;
      saved = left[j - r] * temp;
    }
    N[j] = saved;
  }
}

// Least-squares fit of a uniform B-spline of order `order` (spacing dt) to the three axes of
// `signal`; returns every sample's squared residual summed over the axes, and *coefficients.
std::vector<double> FitResiduals(const std::vector<double>& t_s,
                                 const std::vector<Eigen::Vector3d>& signal, int order, double dt,
                                 int* coefficients) {
  const int p = order - 1;
  const double span = t_s.back() - t_s.front();
  const int segments = std::max(1, static_cast<int>(std::ceil(span / dt - 1e-9)));
  const int M = segments + p;
  *coefficients = M;
  std::vector<Eigen::Triplet<double>> entries;
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(M, 3);
  std::vector<int> seg(t_s.size());
  std::vector<double> basis(t_s.size() * static_cast<std::size_t>(order));
  for (std::size_t i = 0; i < t_s.size(); ++i) {
    const double x = (t_s[i] - t_s.front()) / dt;
    const int s = std::min(static_cast<int>(std::floor(x)), segments - 1);
    seg[i] = s;
    double* N = &basis[i * static_cast<std::size_t>(order)];
    UniformBasis(p, x - s, N);
    for (int a = 0; a <= p; ++a) {
      rhs.row(s + a) += N[a] * signal[i].transpose();
      for (int b = 0; b <= p; ++b)
        entries.emplace_back(s + a, s + b, N[a] * N[b]);
    }
  }
  // A coefficient no sample reaches (a gap) stays at zero by a small ridge.
  for (int m = 0; m < M; ++m)
    entries.emplace_back(m, m, 1e-9);
  Eigen::SparseMatrix<double> A(M, M);
  A.setFromTriplets(entries.begin(), entries.end());
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
  const Eigen::MatrixXd c = ldlt.solve(rhs);
  std::vector<double> squared(t_s.size());
  for (std::size_t i = 0; i < t_s.size(); ++i) {
    const double* N = &basis[i * static_cast<std::size_t>(order)];
    Eigen::Vector3d fit = Eigen::Vector3d::Zero();
    for (int a = 0; a <= p; ++a)
      fit += N[a] * c.row(seg[i] + a).transpose();
    squared[i] = (signal[i] - fit).squaredNorm();
  }
  return squared;
}

}  // namespace

KnotFitChoice ChooseKnotSpacingByFit(const std::vector<std::int64_t>& t_ns,
                                     const std::vector<Eigen::Vector3d>& gyro,
                                     const std::vector<Eigen::Vector3d>& accel,
                                     const KnotFitOptions& options) {
  if (t_ns.size() != gyro.size() || t_ns.size() != accel.size() || t_ns.size() < 64)
    throw std::invalid_argument("knot spacing: need at least 64 IMU samples with gyro and accel");
  if (options.order < 3 || options.order > 8)
    throw std::invalid_argument("knot spacing: the spline order must be 3 .. 8");
  std::vector<double> t_s(t_ns.size());
  for (std::size_t i = 0; i < t_ns.size(); ++i)
    t_s[i] = 1e-9 * static_cast<double>(t_ns[i] - t_ns.front());
  const double span = t_s.back();
  if (!(span > 0.0))
    throw std::invalid_argument("knot spacing: IMU time span is zero");
  const double rate = static_cast<double>(t_s.size() - 1) / span;
  int windows = std::max(1, static_cast<int>(std::floor(span / options.window_s)));
  if (span - windows * options.window_s >= 0.5 * options.window_s)
    ++windows;
  std::vector<int> window_of(t_s.size());
  for (std::size_t i = 0; i < t_s.size(); ++i)
    window_of[i] = std::min(static_cast<int>(t_s[i] / options.window_s), windows - 1);

  // The ladder: from two samples per knot (finer leaves nothing to judge the fit by) up.
  std::vector<double> ladder;
  for (double dt = std::max(options.min_spacing_s, 2.0 / rate);
       dt <= options.max_spacing_s * 1.0001; dt *= options.ladder_ratio)
    ladder.push_back(dt);
  if (ladder.empty())
    ladder.push_back(options.max_spacing_s);

  // s_w^2(dt) per signal, window and candidate.
  const std::size_t W = static_cast<std::size_t>(windows);
  std::vector<std::vector<double>> var_g(ladder.size(), std::vector<double>(W, 0.0));
  std::vector<std::vector<double>> var_a = var_g;
  std::vector<double> count(W, 0.0);
  for (std::size_t i = 0; i < t_s.size(); ++i)
    count[static_cast<std::size_t>(window_of[i])] += 3.0;
  for (std::size_t j = 0; j < ladder.size(); ++j) {
    for (int which = 0; which < 2; ++which) {
      int M = 0;
      const std::vector<double> sq =
          which == 0 ? FitResiduals(t_s, gyro, options.order - 1, ladder[j], &M)
                     : FitResiduals(t_s, accel, std::max(2, options.order - 2), ladder[j], &M);
      std::vector<double>& var = which == 0 ? var_g[j] : var_a[j];
      for (std::size_t i = 0; i < sq.size(); ++i)
        var[static_cast<std::size_t>(window_of[i])] += sq[i];
      const double redundancy = std::max(1.0 - static_cast<double>(M) / t_s.size(), 1e-3);
      for (std::size_t w = 0; w < W; ++w)
        var[w] /= std::max(count[w], 1.0) * redundancy;
    }
  }
  KnotFitChoice out;
  out.knot_spacing_s = ladder.front();
  for (std::size_t j = 0; j < ladder.size(); ++j) {
    KnotFitCandidate c;
    c.spacing_s = ladder[j];
    double worst = -1.0;
    std::vector<double> excess(W, 0.0);
    for (std::size_t w = 0; w < W; ++w) {
      double min_g = var_g[0][w], min_a = var_a[0][w];
      for (std::size_t k = 1; k < ladder.size(); ++k) {
        min_g = std::min(min_g, var_g[k][w]);
        min_a = std::min(min_a, var_a[k][w]);
      }
      const double eg = min_g > 0.0 ? var_g[j][w] / min_g - 1.0 : 0.0;
      const double ea = min_a > 0.0 ? var_a[j][w] / min_a - 1.0 : 0.0;
      excess[w] = std::max(eg, ea);
      c.gyro_excess = std::max(c.gyro_excess, eg);
      c.accel_excess = std::max(c.accel_excess, ea);
      if (std::max(eg, ea) > worst) {
        worst = std::max(eg, ea);
        c.worst_window = static_cast<int>(w);
      }
    }
    const auto q = static_cast<std::size_t>(
        std::ceil(options.window_share * static_cast<double>(W)) - 1.0 + 1e-9);
    std::nth_element(excess.begin(),
                     excess.begin() + static_cast<std::ptrdiff_t>(std::min(q, W - 1)),
                     excess.end());
    c.share_excess = excess[std::min(q, W - 1)];
    out.candidates.push_back(c);
  }
  // The largest spacing below which every candidate also fits (the misfit grows with the
  // spacing; the first failure ends the search).
  for (const KnotFitCandidate& c : out.candidates) {
    if (c.share_excess > options.misfit_tolerance)
      break;
    out.knot_spacing_s = c.spacing_s;
  }
  return out;
}

}  // namespace ctcal
