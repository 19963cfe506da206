#include "ctcal/calibrator/noise/variance_components.h"

#include <Eigen/SparseCholesky>
#include <stdexcept>

namespace ctcal {

namespace {

// splitmix64: a fast, seedable generator whose sequence does not depend on the library.
std::uint64_t Next(std::uint64_t* state) {
  std::uint64_t z = (*state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

}  // namespace

HatTraces::HatTraces(int num_columns, int num_groups, const RedundancyOptions& options)
    : columns_(num_columns),
      groups_(num_groups),
      options_(options),
      exact_(num_columns <= options.exact_max_columns),
      N_(num_columns, num_columns),
      state_(options.seed) {
  if (options_.probes < 1)
    throw std::invalid_argument("HatTraces: probes must be >= 1");
  if (exact_)
    N_k_.assign(static_cast<std::size_t>(groups_), Eigen::MatrixXd::Zero(columns_, columns_));
  else
    B_ = Eigen::MatrixXd::Zero(columns_, static_cast<Eigen::Index>(groups_) * options_.probes);
}

HatTraces::~HatTraces() = default;

void HatTraces::Add(const ceres::CRSMatrix& J, const std::vector<int>& row_group) {
  if (J.num_cols != columns_ || static_cast<int>(row_group.size()) != J.num_rows)
    throw std::invalid_argument("HatTraces::Add: the chunk's shape does not match");
  const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor, int>> Jm(
      J.num_rows, J.num_cols, static_cast<Eigen::Index>(J.values.size()), J.rows.data(),
      J.cols.data(), J.values.data());
  const Eigen::SparseMatrix<double> JtJ = Jm.transpose() * Jm;
  N_ += JtJ;
  for (int i = 0; i < J.num_rows; ++i) {
    const int k = row_group[static_cast<std::size_t>(i)];
    if (k < 0)
      continue;
    if (k >= groups_)
      throw std::invalid_argument("HatTraces::Add: group out of range");
    const int begin = J.rows[static_cast<std::size_t>(i)];
    const int end = J.rows[static_cast<std::size_t>(i) + 1];
    if (exact_) {
      Eigen::MatrixXd& Nk = N_k_[static_cast<std::size_t>(k)];
      for (int a = begin; a < end; ++a) {
        for (int b = begin; b < end; ++b)
          Nk(J.cols[static_cast<std::size_t>(a)], J.cols[static_cast<std::size_t>(b)]) +=
              J.values[static_cast<std::size_t>(a)] * J.values[static_cast<std::size_t>(b)];
      }
      continue;
    }
    for (int p = 0; p < options_.probes; ++p) {
      const double z = (Next(&state_) & 1U) != 0U ? 1.0 : -1.0;
      const Eigen::Index col = static_cast<Eigen::Index>(k) * options_.probes + p;
      for (int a = begin; a < end; ++a)
        B_(J.cols[static_cast<std::size_t>(a)], col) += z * J.values[static_cast<std::size_t>(a)];
    }
  }
}

std::vector<double> HatTraces::Compute() {
  // Columns no row reads (a knot past the data) have a zero diagonal: a unit there keeps the
  // factorisation defined without touching any trace; a tiny relative ridge covers near-singular
  // directions (a weak gauge), where the data's own N_k are negligible anyway.
  double largest = 0.0;
  for (int j = 0; j < columns_; ++j)
    largest = std::max(largest, N_.coeff(j, j));
  if (!(largest > 0.0))
    throw std::runtime_error("noise estimation: the Jacobian is empty");
  Eigen::SparseMatrix<double> ridge(columns_, columns_);
  ridge.setIdentity();
  for (int j = 0; j < columns_; ++j)
    ridge.coeffRef(j, j) = N_.coeff(j, j) > 0.0 ? 1e-10 * largest : largest;
  const Eigen::SparseMatrix<double> A = N_ + ridge;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
  if (ldlt.info() != Eigen::Success)
    throw std::runtime_error("noise estimation: the normal equations cannot be factored");
  std::vector<double> traces(static_cast<std::size_t>(groups_), 0.0);
  if (exact_) {
    const Eigen::MatrixXd inverse = ldlt.solve(Eigen::MatrixXd::Identity(columns_, columns_));
    for (int k = 0; k < groups_; ++k)
      traces[static_cast<std::size_t>(k)] =
          inverse.cwiseProduct(N_k_[static_cast<std::size_t>(k)]).sum();
    return traces;
  }
  const Eigen::MatrixXd X = ldlt.solve(B_);
  for (int k = 0; k < groups_; ++k) {
    double sum = 0.0;
    for (int p = 0; p < options_.probes; ++p) {
      const Eigen::Index col = static_cast<Eigen::Index>(k) * options_.probes + p;
      sum += B_.col(col).dot(X.col(col));
    }
    traces[static_cast<std::size_t>(k)] = sum / options_.probes;
  }
  return traces;
}

}  // namespace ctcal
