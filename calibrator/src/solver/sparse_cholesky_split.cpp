// SplitFactor (sparse_cholesky_impl.h): the nuisance block factored as two halves on two threads
// and a dense separator.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstring>

#include "ctcal/sensors/parallel_for.h"
#include "sparse_cholesky_impl.h"

namespace ctcal {

namespace {

// METIS' vertex separator of the matrix's graph (CHOLMOD's interface to it), on the graph of its
// column groups: runs of consecutive columns whose lower pattern is the next one's plus its own
// diagonal (a parameter block's columns, a knot's rotation and translation), one vertex each,
// weighted by its columns. cholmod_bisect would first copy the whole pattern into both triangles
// (~8 MB on EuRoC's 36 s, at the solve's memory peak); this graph is ~6x smaller. *part: per
// column 0, 1 (the halves) or 2 (the separator). Returns -1 where METIS failed.
std::int64_t Bisect(int n, const int* p, const int* rows, std::vector<int>* part) {
  std::vector<int> group_of(static_cast<std::size_t>(n)), weight;
  for (int j = 0; j < n; ++j) {
    const int a = j - 1;
    const bool joins = j > 0 && p[j] - p[a] == p[j + 1] - p[j] + 1 && rows[p[a]] == a &&
                       std::equal(rows + p[a] + 1, rows + p[j], rows + p[j]);
    if (!joins)
      weight.push_back(0);
    group_of[static_cast<std::size_t>(j)] = static_cast<int>(weight.size()) - 1;
    ++weight.back();
  }
  const auto groups = static_cast<int>(weight.size());
  // Each pair of adjacent groups once (a stamp per lower group), then both triangles' columns.
  std::vector<std::pair<int, int>> edges;
  std::vector<int> stamp(static_cast<std::size_t>(groups), -1);
  for (int j = 0; j < n; ++j) {
    const int gj = group_of[static_cast<std::size_t>(j)];
    for (int e = p[j]; e < p[j + 1]; ++e) {
      const int gi = group_of[static_cast<std::size_t>(rows[e])];
      if (gi != gj && stamp[static_cast<std::size_t>(gi)] != gj) {
        stamp[static_cast<std::size_t>(gi)] = gj;
        edges.emplace_back(gi, gj);
      }
    }
  }
  // A pair can be recorded from two columns of one group only once per group (the stamp), but
  // rows of one group reach a lower group from several of its columns: duplicates removed here.
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<int> start(static_cast<std::size_t>(groups) + 1, 0), index(2 * edges.size());
  for (const auto& [a, b] : edges) {
    ++start[static_cast<std::size_t>(a) + 1];
    ++start[static_cast<std::size_t>(b) + 1];
  }
  for (int g = 0; g < groups; ++g)
    start[static_cast<std::size_t>(g) + 1] += start[static_cast<std::size_t>(g)];
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (const auto& [a, b] : edges) {
      index[static_cast<std::size_t>(fill[static_cast<std::size_t>(a)]++)] = b;
      index[static_cast<std::size_t>(fill[static_cast<std::size_t>(b)]++)] = a;
    }
  }
  cholmod_sparse graph{};
  graph.nrow = graph.ncol = static_cast<std::size_t>(groups);
  graph.nzmax = index.size();
  graph.p = start.data();
  graph.i = index.data();
  graph.stype = 0;
  graph.itype = CHOLMOD_INT;
  graph.xtype = CHOLMOD_PATTERN;
  graph.dtype = CHOLMOD_DOUBLE;
  graph.packed = 1;
  std::vector<int> group_part(static_cast<std::size_t>(groups));
  cholmod_common common;
  cholmod_start(&common);
  common.print = 0;
  const auto separated =
      cholmod_metis_bisector(&graph, weight.data(), nullptr, group_part.data(), &common);
  const bool ok = common.status == CHOLMOD_OK;
  cholmod_finish(&common);
  if (!ok)
    return -1;
  part->resize(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j)
    (*part)[static_cast<std::size_t>(j)] =
        group_part[static_cast<std::size_t>(group_of[static_cast<std::size_t>(j)])];
  return separated;
}

}  // namespace

std::unique_ptr<SplitFactor> SplitFactor::Analyze(const SparseColMajor& lower) {
  const int n = static_cast<int>(lower.cols());
  if (n < kMinColumns || !lower.isCompressed())
    return nullptr;
  const int* p = lower.outerIndexPtr();
  const int* rows = lower.innerIndexPtr();

  std::vector<int> part;
  if (Bisect(n, p, rows, &part) < 0)
    return nullptr;
  auto split = std::make_unique<SplitFactor>();
  split->part.assign(part.begin(), part.end());
  split->local.resize(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) {
    const int k = part[static_cast<std::size_t>(j)];
    std::vector<int>& to = k == 2 ? split->separator : split->half[k].global;
    split->local[static_cast<std::size_t>(j)] = static_cast<int>(to.size());
    to.push_back(j);
  }
  const auto s = static_cast<int>(split->separator.size());
  if (s < 1 || s > kMaxSeparator)
    return nullptr;
  for (const Half& h : split->half) {
    if (4 * static_cast<std::int64_t>(h.global.size()) < n)
      return nullptr;
  }
  const std::vector<int>& local = split->local;

  // The entries between the halves and the separator, and within the separator.
  std::vector<std::vector<char>> coupled(2);
  for (int k = 0; k < 2; ++k)
    coupled[static_cast<std::size_t>(k)].assign(split->half[k].global.size(), 0);
  std::vector<Coupling> couplings[2];  // rows still local indices
  for (int j = 0; j < n; ++j) {
    const int pj = part[static_cast<std::size_t>(j)];
    for (int e = p[j]; e < p[j + 1]; ++e) {
      const int i = rows[e];
      const int pi = part[static_cast<std::size_t>(i)];
      const int li = local[static_cast<std::size_t>(i)], lj = local[static_cast<std::size_t>(j)];
      if (pi == pj && pi < 2)
        continue;
      if (pi == 2 && pj == 2) {
        split->separator_entries.emplace_back(e, std::max(li, lj), std::min(li, lj));
      } else if (pi == 2 || pj == 2) {
        const int k = pi == 2 ? pj : pi;
        const int row = pi == 2 ? lj : li;
        couplings[k].push_back(Coupling{e, row, pi == 2 ? li : lj});
        coupled[static_cast<std::size_t>(k)][static_cast<std::size_t>(row)] = 1;
      } else {
        return nullptr;  // not a separator (cannot happen for METIS' result)
      }
    }
  }
  // The columns coupled to the separator go last in their half's order (their W rows are then a
  // tail), and with them the dense columns next to them (a bias knot couples to a second of
  // trajectory knots): eliminated before those, it would fill all of them in with each other.
  {
    std::vector<int> degree(static_cast<std::size_t>(n), 0);
    for (int j = 0; j < n; ++j) {
      for (int e = p[j]; e < p[j + 1]; ++e) {
        ++degree[static_cast<std::size_t>(j)];
        if (rows[e] != j)
          ++degree[static_cast<std::size_t>(rows[e])];
      }
    }
    std::vector<int> sorted = degree;
    std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
    const int dense = 4 * sorted[static_cast<std::size_t>(n / 2)];
    for (int j = 0; j < n; ++j) {
      const int pj = part[static_cast<std::size_t>(j)];
      for (int e = p[j]; e < p[j + 1]; ++e) {
        const int i = rows[e];
        if (part[static_cast<std::size_t>(i)] != pj || pj == 2)
          continue;
        auto& c = coupled[static_cast<std::size_t>(pj)];
        const int li = local[static_cast<std::size_t>(i)], lj = local[static_cast<std::size_t>(j)];
        if (c[static_cast<std::size_t>(li)] == 1 && degree[static_cast<std::size_t>(j)] >= dense)
          c[static_cast<std::size_t>(lj)] = 2;
        if (c[static_cast<std::size_t>(lj)] == 1 && degree[static_cast<std::size_t>(i)] >= dense)
          c[static_cast<std::size_t>(li)] = 2;
      }
    }
  }
  // Each half's pattern (its entries in the matrix's order, local indices), analysed and dropped
  // before the next is built.
  for (int k = 0; k < 2; ++k) {
    Half& h = split->half[k];
    const int nk = static_cast<int>(h.global.size());
    std::vector<int> start(static_cast<std::size_t>(nk) + 1, 0), half_rows;
    for (int lj = 0; lj < nk; ++lj) {
      const int j = h.global[static_cast<std::size_t>(lj)];
      int count = 0;
      for (int e = p[j]; e < p[j + 1]; ++e)
        count += part[static_cast<std::size_t>(rows[e])] == k;
      start[static_cast<std::size_t>(lj) + 1] = start[static_cast<std::size_t>(lj)] + count;
    }
    half_rows.reserve(static_cast<std::size_t>(start[static_cast<std::size_t>(nk)]));
    for (const int j : h.global) {
      for (int e = p[j]; e < p[j + 1]; ++e) {
        if (part[static_cast<std::size_t>(rows[e])] == k)
          half_rows.push_back(local[static_cast<std::size_t>(rows[e])]);
      }
    }
    std::vector<int> last_set;
    for (std::size_t i = 0; i < coupled[static_cast<std::size_t>(k)].size(); ++i) {
      if (coupled[static_cast<std::size_t>(k)][i])
        last_set.push_back(static_cast<int>(i));
    }
    h.factor.Analyze(nk, start.data(), half_rows.data(), last_set);
    // CHOLMOD's switch would make this half supernodal (many sensors): the single factor's
    // choice, whose supernodes pay there.
    if (h.factor.factor_->is_super ||
        h.factor.common_.fl >= SparseCholesky::kSupernodalSwitch * h.factor.common_.lnz)
      return nullptr;
    const std::vector<int> position = h.factor.Positions();
    h.tail = nk;
    for (const Coupling& c : couplings[k])
      h.tail = std::min(h.tail, position[static_cast<std::size_t>(c.row)]);
    for (Coupling& c : couplings[k])
      c.row = position[static_cast<std::size_t>(c.row)] - h.tail;
    h.coupling = std::move(couplings[k]);
    h.factor.gather_.resize(h.global.size());
    for (std::size_t q = 0; q < h.global.size(); ++q)
      h.factor.gather_[q] = h.global[static_cast<std::size_t>(h.factor.perm_[q])];
  }
  split->outer.assign(p, p + n + 1);
  return split;
}

// Every entry where the analysis put it: the same count per column (outer), each half's entries
// at their factor slots' rows and columns (SingleFactor::SameAsAnalysed's test, streamed), the
// couplings and the separator's entries at their indices. The map is one to one, so this is the
// same pattern, without a copy of it kept.
bool SplitFactor::SameAsAnalysed(const SparseColMajor& lower) const {
  const int n = static_cast<int>(lower.cols());
  if (!lower.isCompressed() || outer.size() != static_cast<std::size_t>(n) + 1 ||
      !std::equal(outer.begin(), outer.end(), lower.outerIndexPtr()))
    return false;
  const int* p = lower.outerIndexPtr();
  const int* rows = lower.innerIndexPtr();
  std::size_t at[2] = {0, 0}, coupling_at[2] = {0, 0}, separator_at = 0;
  std::vector<int> position[2] = {half[0].factor.Positions(), half[1].factor.Positions()};
  for (int j = 0; j < n; ++j) {
    const int pj = part[static_cast<std::size_t>(j)];
    const int lj = local[static_cast<std::size_t>(j)];
    for (int e = p[j]; e < p[j + 1]; ++e) {
      const int i = rows[e];
      if (i < j)
        return false;
      const int pi = part[static_cast<std::size_t>(i)];
      const int li = local[static_cast<std::size_t>(i)];
      if (pi == pj && pi < 2) {
        const SingleFactor& f = half[pi].factor;
        if (at[pi] >= f.target_.size() ||
            !f.Holds(f.target_[at[pi]++], position[pi][static_cast<std::size_t>(li)],
                     position[pi][static_cast<std::size_t>(lj)]))
          return false;
      } else if (pi == 2 && pj == 2) {
        if (separator_at >= separator_entries.size() ||
            separator_entries[separator_at++] != std::make_tuple(e, li, lj))
          return false;
      } else if (pi == 2 || pj == 2) {
        const int k = pi == 2 ? pj : pi;
        const Half& h = half[k];
        const int row = position[k][static_cast<std::size_t>(pi == 2 ? lj : li)] - h.tail;
        if (coupling_at[k] >= h.coupling.size())
          return false;
        const Coupling& c = h.coupling[coupling_at[k]++];
        if (c.entry != e || c.row != row || c.column != (pi == 2 ? li : lj))
          return false;
      } else {
        return false;
      }
    }
  }
  return at[0] == half[0].factor.target_.size() && at[1] == half[1].factor.target_.size() &&
         coupling_at[0] == half[0].coupling.size() && coupling_at[1] == half[1].coupling.size() &&
         separator_at == separator_entries.size();
}

bool SplitFactor::Factorize(const SparseColMajor& lower, const Eigen::VectorXd& d) {
  const double* v = lower.valuePtr();
  const auto s = static_cast<Eigen::Index>(separator.size());
  char factored[2] = {0, 0};
  // Everything a factorisation allocates is allocated on the calling thread: allocated on the
  // helper thread, it landed in that thread's heap arena, whose pages the calling thread's later
  // allocations cannot reuse (EuRoC's 36 s: the cross-validation's subset peaked 5 MB higher). The
  // first factorisation after the analysis runs the halves one after the other here (CHOLMOD's
  // work arrays, W, D^-1/2: kept, the later ones reuse them), and the values ReleaseNumeric
  // freed (the factor's and the permuted copy of A_k) are allocated again before the threads
  // start.
  for (Half& h : half)
    h.factor.AllocateNumeric();
  ParallelFor(first_done ? 2 : 1, 2, [&](std::size_t k) {
    Half& h = half[k];
    // A_k + D_k straight into the factor's permuted copy (SingleFactor::Factorize's scatter).
    const int* p = lower.outerIndexPtr();
    const int* rows = lower.innerIndexPtr();
    std::vector<double>& values = h.factor.values_;  // sized by AllocateNumeric
    std::size_t at = 0;
    for (const int j : h.global) {
      for (int e = p[j]; e < p[j + 1]; ++e) {
        if (part[static_cast<std::size_t>(rows[e])] != static_cast<char>(k))
          continue;
        values[static_cast<std::size_t>(h.factor.target_[at++])] =
            v[e] + (rows[e] == j ? d(j) : 0.0);
      }
    }
    if (!h.factor.FactorizeValues())
      return;
    // W_k = R_k^-T C_k = D^-1/2 L^-1 (P C_k) on the tail: L's unit diagonal, column by column,
    // each finished row of W subtracted from the rows below it that L's column names.
    const auto m = static_cast<Eigen::Index>(h.global.size()) - h.tail;
    h.W.setZero(m, s);
    for (const Coupling& c : h.coupling)
      h.W(c.row, c.column) += v[c.entry];
    const cholmod_factor* L = h.factor.factor_;
    const int* Lp = static_cast<const int*>(L->p);
    const int* Li = static_cast<const int*>(L->i);
    const int* Lnz = static_cast<const int*>(L->nz);
    const double* Lx = static_cast<const double*>(L->x);
    for (Eigen::Index r = 0; r < m; ++r) {
      const int col = h.tail + static_cast<int>(r);
      for (int e = Lp[col] + 1; e < Lp[col] + Lnz[col]; ++e)
        h.W.row(Li[e] - h.tail) -= Lx[e] * h.W.row(r);
    }
    for (Eigen::Index r = 0; r < m; ++r)
      h.W.row(r) *= h.factor.half_scale_[static_cast<std::size_t>(h.tail + r)];
    h.gram.noalias() = h.W.transpose() * h.W;
    factored[k] = 1;
  });
  if (!factored[0] || !factored[1])
    return false;
  first_done = true;
  Eigen::MatrixXd S = -half[0].gram - half[1].gram;
  for (const auto& [e, i, j] : separator_entries) {
    S(i, j) += v[e];
    if (i != j)
      S(j, i) += v[e];
  }
  for (Eigen::Index i = 0; i < s; ++i)
    S(i, i) += d(separator[static_cast<std::size_t>(i)]);
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success || !S.allFinite())
    return false;
  L_s = llt.matrixL();
  return true;
}

void SplitFactor::ReleaseNumeric() {
  for (Half& h : half) {
    h.factor.ReleaseNumeric();
    h.W = RowMajor();
  }
  solve_.Release();
}

double SplitFactor::NonZeros() const {
  double nnz = 0.5 * static_cast<double>(separator.size() * (separator.size() + 1));
  for (const Half& h : half)
    nnz += h.factor.common_.lnz + static_cast<double>(h.W.size());
  return nnz;
}

double SplitFactor::Flops() const {
  double flops = 0.0;
  for (const Half& h : half)
    flops += h.factor.common_.fl;
  return flops;
}

// R^T y = b by blocks: y_k = R_k^-T b_k, y_s = R_s^-T (b_s - W_0^T y_0 - W_1^T y_1). The rows of y
// are the halves' factor orders, then the separator's.
bool SplitFactor::HalfSolve(const Eigen::Ref<const Eigen::MatrixXd>& B, const Eigen::VectorXd* last,
                            Eigen::Ref<Eigen::MatrixXd> X, WorkspaceImpl* w) const {
  const Eigen::Index cols = B.cols() + (last != nullptr ? 1 : 0);
  const auto s = static_cast<Eigen::Index>(separator.size());
  Eigen::MatrixXd rhs_s(s, cols);
  for (Eigen::Index i = 0; i < s; ++i) {
    const int g = separator[static_cast<std::size_t>(i)];
    rhs_s.row(i).head(B.cols()) = B.row(g);
    if (last != nullptr)
      rhs_s(i, B.cols()) = (*last)(g);
  }
  Eigen::Index offset = 0;
  for (int k = 0; k < 2; ++k) {
    const Half& h = half[k];
    const auto nk = static_cast<Eigen::Index>(h.global.size());
    auto Xk = X.middleRows(offset, nk);
    // B's rows of the half read through its gather map (SingleFactor::gather_).
    if (!h.factor.HalfSolve(B, last, Xk, k == 0 ? w : w->Second()))
      return false;
    // Column by column, as below: a column's bits do not depend on the others solved with it
    // (the single factor's property, which the chunks of the border's solves rely on).
    for (Eigen::Index c = 0; c < cols; ++c)
      rhs_s.col(c).noalias() -= h.W.transpose() * Xk.col(c).tail(h.W.rows());
    offset += nk;
  }
  for (Eigen::Index c = 0; c < cols; ++c)
    X.col(c).tail(s) = L_s.triangularView<Eigen::Lower>().solve(rhs_s.col(c));
  return X.allFinite();
}

// R x = y by blocks: x_s = R_s^-1 y_s, x_k = R_k^-1 (y_k - W_k x_s), back in A's order.
bool SplitFactor::HalfSolveBack(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd* Y,
                                WorkspaceImpl* w) const {
  const auto s = static_cast<Eigen::Index>(separator.size());
  const Eigen::Index cols = X.cols();
  Eigen::MatrixXd x_s(s, cols);
  for (Eigen::Index c = 0; c < cols; ++c)
    x_s.col(c) = L_s.transpose().triangularView<Eigen::Upper>().solve(X.col(c).tail(s));
  Y->resize(X.rows(), cols);
  Eigen::Index offset = 0;
  for (int k = 0; k < 2; ++k) {
    const Half& h = half[k];
    const auto nk = static_cast<Eigen::Index>(h.global.size());
    Eigen::MatrixXd Zk = X.middleRows(offset, nk);
    for (Eigen::Index c = 0; c < cols; ++c)
      Zk.col(c).tail(h.W.rows()).noalias() -= h.W * x_s.col(c);
    // Y's rows of the half written through its gather map.
    if (!h.factor.HalfSolveBack(Zk, Y, k == 0 ? w : w->Second()))
      return false;
    offset += nk;
  }
  for (Eigen::Index i = 0; i < s; ++i)
    Y->row(separator[static_cast<std::size_t>(i)]) = x_s.row(i);
  return Y->allFinite();
}

bool SplitFactor::Solve(const Eigen::MatrixXd& B, Eigen::MatrixXd* X, WorkspaceImpl* w) const {
  Eigen::MatrixXd half_solved(B.rows(), B.cols());
  return HalfSolve(B, nullptr, half_solved, w) && HalfSolveBack(half_solved, X, w);
}

}  // namespace ctcal
