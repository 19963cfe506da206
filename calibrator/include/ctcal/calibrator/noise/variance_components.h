// Variance component estimation (Helmert / Foerstner): the noise level of every sensor group from
// the residuals of the solve itself (docs/noise_estimation.md).
//
// A group k (a camera's corners, an IMU's gyro rows, its accelerometer rows) enters the
// least-squares problem whitened by its current sigma_k, W_k = I / sigma_k^2. At the solution
// x^ of min sum_k e_k^T W_k e_k, with J the whitened Jacobian and N = J^T J, the hat matrix
// H = J N^-1 J^T projects the whitened observations onto the fitted ones; its diagonal block of
// group k has trace t_k = tr(N^-1 N_k), N_k = J_k^T J_k, and
//
//   E[e_k^T W_k e_k] = (sigma_true,k^2 / sigma_k^2) r_k,    r_k = n_k - t_k   (redundancy),
//
// so sigma_k^2 <- sigma_k^2 (e_k^T W_k e_k) / r_k is unbiased for the true variance when the other
// groups' weights are right; iterating solve -> update -> re-solve converges to the fixed point
// (Foerstner 1979). The redundancies sum with the priors' to n - u. t_k needs N^-1: exactly
// (dense) for small problems, else by Hutchinson's estimator
//
//   t_k = E_z[ z_k^T J_k N^-1 J_k^T z_k ],   z_k Rademacher on group k's rows,
//
// one sparse solve per probe and group; its standard deviation sqrt(2 |H_kk|_F^2) <= sqrt(2 t_k)
// is small against n_k for the large groups here (a camera, 10^4-10^6 rows).
#pragma once

#include <ceres/crs_matrix.h>

#include <Eigen/SparseCore>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace ctcal {

struct RedundancyOptions {
  int probes = 6;                 // Hutchinson probes per group
  int exact_max_columns = 800;    // at most this many parameters: tr(N^-1 N_k) exactly
  std::uint64_t seed = 20261128;  // the probes' generator (the result is reproducible)
};

// Accumulates the whitened Jacobian chunk by chunk (rows labelled with their group, -1 for rows
// of no group: priors, bias random walks) and returns every group's hat-matrix trace t_k.
class HatTraces {
 public:
  HatTraces(int num_columns, int num_groups, const RedundancyOptions& options = {});
  ~HatTraces();
  HatTraces(const HatTraces&) = delete;
  HatTraces& operator=(const HatTraces&) = delete;

  // J: a chunk of rows over all num_columns columns; row_group[i] the group of its row i.
  void Add(const ceres::CRSMatrix& J, const std::vector<int>& row_group);
  // The traces t_k (N regularised by 1e-10 of its largest diagonal where it is singular).
  // Throws std::runtime_error when N cannot be factored.
  std::vector<double> Compute();
  bool exact() const { return exact_; }

 private:
  int columns_;
  int groups_;
  RedundancyOptions options_;
  bool exact_;
  Eigen::SparseMatrix<double> N_;
  std::vector<Eigen::MatrixXd> N_k_;  // exact: every group's J_k^T J_k
  Eigen::MatrixXd B_;                 // Hutchinson: J_k^T z_k,p in column k * probes + p
  std::uint64_t state_;
};

// One noise group's statistics at a solution and its VCE update.
struct VarianceComponent {
  std::string name;       // e.g. "cam0", "imu0 gyro"
  double weighted = 0.0;  // e^T W e with the weights of the solve
  double count = 0.0;     // n: scalar residuals
  double trace = 0.0;     // t = tr(N^-1 N_k)
  double Redundancy() const { return count - trace; }
  // sigma_new^2 / sigma_used^2 = e^T W e / r (1 when the group has no redundancy left).
  double VarianceFactor() const {
    const double r = Redundancy();
    return r > 0.5 ? weighted / r : 1.0;
  }
};

// The variance factor of one part of a sensor (a camera's frame, an inertial sensor's noise
// window), shrunk toward the sensor's: the part's own e_f^T W e_f over its redundancy r_f weighs
// against nu pseudo-residuals at the sensor's factor s^2 (a scaled inverse-chi-square prior with
// nu degrees of freedom):
//   s_f^2 = (e_f^T W e_f + nu s^2) / (r_f + nu).
inline double ShrunkVariance(double weighted_f, double redundancy_f, double sensor_factor,
                             double nu) {
  return (weighted_f + nu * sensor_factor) / (redundancy_f + nu);
}

}  // namespace ctcal
