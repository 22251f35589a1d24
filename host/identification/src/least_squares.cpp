#include "host_id/least_squares.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <sstream>

#include "delta/input_error.hpp"
#include "host_id/parallel.hpp"

namespace host_id {

namespace {

// The passes over the rows share them out in chunks of this many rows,
// each summed alone and the sums added in order: the same result on any
// number of threads.
constexpr Eigen::Index kRowChunk = 16384;

// How many chunks `rows` rows make (at least one).
Eigen::Index row_chunks(Eigen::Index rows) {
  return std::max<Eigen::Index>(1, (rows + kRowChunk - 1) / kRowChunk);
}

// Each joint's rows scaled by the square root of its weight as they are
// read: the weighted problem solved as an ordinary one, without a weighted
// copy of the rows. Unweighted, every scale is 1 and every product with it
// exact.
struct RowScale {
  std::array<double, 3> by_joint{1.0, 1.0, 1.0};
  bool any() const { return by_joint != std::array<double, 3>{1.0, 1.0, 1.0}; }
  double of(const Equations& r, std::size_t row) const { return by_joint[r.joint[row]]; }
  // The weights themselves, the squares of the scales.
  std::array<double, 3> weights() const {
    return {by_joint[0] * by_joint[0], by_joint[1] * by_joint[1], by_joint[2] * by_joint[2]};
  }
};

// The lagged score sum of one series of score rows g_k (k = 0 .. n-1, zero
// outside), with Bartlett weights:
//   S = sum over |l| <= L of (1 - |l|/(L+1)) sum_k g_k^T g_(k+l).
// The Bartlett triangle is the autocorrelation of a box of L + 1 samples, so
//   S = sum over m = 0 .. n+L-1 of box_m^T box_m / (L + 1),
//   box_m = sum of g over [m - L, m]:
// a Gram matrix of the running box sums (positive semi-definite by
// construction), summed here without the 1 / (L + 1). The rows taken in
// order go through a ring of the last L + 1; the box is re-summed from the
// ring now and then, so that the running sum's rounding does not build up;
// the boxes are multiplied a block at a time (upper triangle).
class BartlettScoreSum {
 public:
  BartlettScoreSum(Eigen::Index p, Eigen::Index lags, Eigen::MatrixXd& s)
      : p_(p),
        width_(lags + 1),
        ring_(static_cast<std::size_t>(width_ * p), 0.0),
        box_(static_cast<std::size_t>(p), 0.0),
        block_(p, kBlockRows),
        s_(s) {}

  // g: p values, or nullptr for a zero row. take_in() only moves the box
  // on (the rows before a chunk); push() also adds the box to the sum.
  void take_in(const double* g) {
    double* old = &ring_[static_cast<std::size_t>((pushed_ % width_) * p_)];
    for (Eigen::Index c = 0; c < p_; ++c) {
      const double v = g ? g[c] : 0.0;
      box_[static_cast<std::size_t>(c)] += v - old[c];
      old[c] = v;
    }
    if (++pushed_ % kResumEvery == 0) resum();
  }
  void push(const double* g) {
    take_in(g);
    double* column = block_.col(in_block_).data();
    for (Eigen::Index c = 0; c < p_; ++c) column[c] = box_[static_cast<std::size_t>(c)];
    if (++in_block_ == kBlockRows) flush();
  }
  // The boxes pushed since the last flush into the sum (upper triangle).
  void flush() {
    s_.selfadjointView<Eigen::Upper>().rankUpdate(block_.leftCols(in_block_));
    in_block_ = 0;
  }

 private:
  static constexpr Eigen::Index kBlockRows = 256;
  static constexpr Eigen::Index kResumEvery = 4096;
  void resum() {
    std::fill(box_.begin(), box_.end(), 0.0);
    for (Eigen::Index i = 0; i < width_; ++i) {
      for (Eigen::Index c = 0; c < p_; ++c) {
        box_[static_cast<std::size_t>(c)] += ring_[static_cast<std::size_t>(i * p_ + c)];
      }
    }
  }
  Eigen::Index p_, width_;
  std::vector<double> ring_, box_;
  Eigen::MatrixXd block_;  // p x kBlockRows: box rows as columns
  Eigen::Index in_block_{0}, pushed_{0};
  Eigen::MatrixXd& s_;
};

// The columns that may be nonzero in joint j's rows: as the regression
// says, or every column where it does not know (or no longer: columns were
// added since).
std::vector<Eigen::Index> columns_of_joint(const Equations& r, unsigned j) {
  if (!r.joint_columns[j].empty() && r.joint_columns_of == r.psi.cols()) {
    return {r.joint_columns[j].begin(), r.joint_columns[j].end()};
  }
  std::vector<Eigen::Index> all(static_cast<std::size_t>(r.psi.cols()));
  for (std::size_t c = 0; c < all.size(); ++c) all[c] = static_cast<Eigen::Index>(c);
  return all;
}

// The row of each joint at each of the n samples, [j n + sample] (-1: none).
std::vector<std::int32_t> rows_by_joint_and_sample(const Equations& r, Eigen::Index n) {
  std::vector<std::int32_t> row_at(3 * static_cast<std::size_t>(n), -1);
  for (std::size_t row = 0; row < r.rows(); ++row) {
    row_at[r.joint[row] * static_cast<std::size_t>(n) + r.sample[row]] =
        static_cast<std::int32_t>(row);
  }
  return row_at;
}

// The chunks' sums (joint j's chunk c at [j chunks + c], over joint j's
// columns) added in order into the upper triangle of a p x p matrix.
Eigen::MatrixXd upper_triangle_of_chunks(const std::vector<Eigen::MatrixXd>& partial,
                                         const std::array<std::vector<Eigen::Index>, 3>& columns,
                                         std::size_t chunks, Eigen::Index p) {
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(p, p);
  for (std::size_t task = 0; task < partial.size(); ++task) {
    const std::vector<Eigen::Index>& used = columns[task / chunks];
    const Eigen::MatrixXd& part = partial[task];
    for (Eigen::Index b = 0; b < part.cols(); ++b) {
      for (Eigen::Index a = 0; a <= b; ++a) {  // the upper triangle
        s(used[static_cast<std::size_t>(a)], used[static_cast<std::size_t>(b)]) += part(a, b);
      }
    }
  }
  return s;
}

// S of the covariance in the scaled coordinates (the columns of Psi divided
// by col_norm), per joint: each joint's scores g_k = a e of its row at
// sample k (zero where it has none), in sample order, through
// BartlettScoreSum, over the columns that are not zero in that joint's rows
// (a column zero in all of them adds nothing). Lags run over the sample
// index, across a gap between segments too (a few pairs). The boxes
// m = 0 .. n+L-1 of each joint are shared out in chunks of fixed length
// (each starts by taking in the L + 1 rows before it), and the chunks' sums
// are added in order: the same result on any number of threads.
Eigen::MatrixXd lagged_score_covariance(const Equations& r, const RowScale& scale,
                                        const Eigen::VectorXd& col_norm,
                                        Eigen::Ref<const Eigen::VectorXd> e, std::size_t lags,
                                        unsigned threads) {
  const Eigen::Index p = r.psi.cols();
  const auto n = static_cast<Eigen::Index>(r.samples());
  const auto l = std::min<Eigen::Index>(static_cast<Eigen::Index>(lags), n);
  const Eigen::VectorXd inverse_norm = col_norm.cwiseInverse();
  const std::array<std::vector<Eigen::Index>, 3> columns{
      columns_of_joint(r, 0), columns_of_joint(r, 1), columns_of_joint(r, 2)};
  const std::vector<std::int32_t> row_at = rows_by_joint_and_sample(r, n);
  constexpr Eigen::Index kChunk = 16384;
  const Eigen::Index boxes = n + l;
  const Eigen::Index chunks = (boxes + kChunk - 1) / kChunk;
  std::vector<Eigen::MatrixXd> partial(3 * static_cast<std::size_t>(chunks));
  const auto chunk_sum = [&](std::size_t, std::size_t task) {
    const auto j = static_cast<Eigen::Index>(task) / chunks;
    const Eigen::Index first = (static_cast<Eigen::Index>(task) % chunks) * kChunk;
    const Eigen::Index last = std::min(boxes, first + kChunk);
    const std::int32_t* rows_of_joint = row_at.data() + j * n;
    const std::vector<Eigen::Index>& used = columns[static_cast<std::size_t>(j)];
    const auto q = static_cast<Eigen::Index>(used.size());
    std::vector<double> g(used.size());
    const auto score = [&](Eigen::Index m) -> const double* {
      const std::int32_t row = m < n ? rows_of_joint[m] : -1;
      if (row < 0) return nullptr;
      const double scaled_e = e(row) * scale.of(r, static_cast<std::size_t>(row));
      for (Eigen::Index k = 0; k < q; ++k) {
        const Eigen::Index c = used[static_cast<std::size_t>(k)];
        g[static_cast<std::size_t>(k)] = r.psi(row, c) * inverse_norm(c) * scaled_e;
      }
      return g.data();
    };
    Eigen::MatrixXd& s = partial[task];
    s = Eigen::MatrixXd::Zero(q, q);
    BartlettScoreSum sum(q, l, s);
    for (Eigen::Index m = std::max<Eigen::Index>(0, first - l - 1); m < first; ++m) {
      sum.take_in(score(m));
    }
    for (Eigen::Index m = first; m < last; ++m) sum.push(score(m));
    sum.flush();
  };
  run_tasks(partial.size(), workers_for(static_cast<std::size_t>(3 * n), threads, 30000),
            chunk_sum);
  Eigen::MatrixXd s =
      upper_triangle_of_chunks(partial, columns, static_cast<std::size_t>(chunks), p);
  s /= static_cast<double>(l + 1);
  return s.selfadjointView<Eigen::Upper>();
}

// A block's rows scaled (the weighted problem's rows) into a buffer.
void scale_rows(const Equations& reg, const RowScale& scale, Eigen::Index start, Eigen::Index len,
                Eigen::MatrixXd& a, Eigen::VectorXd& t) {
  a = reg.psi.middleRows(start, len);
  t = reg.tau.segment(start, len);
  for (Eigen::Index k = 0; k < len; ++k) {
    const double s = scale.of(reg, static_cast<std::size_t>(start + k));
    a.row(k) *= s;
    t(k) *= s;
  }
}

// The products of one block of rows added to g.
template <class Rows, class Tau>
void add_block(const Rows& a, const Tau& t, Eigen::MatrixXd& g) {
  const Eigen::Index p = a.cols();
  g.topLeftCorner(p, p).selfadjointView<Eigen::Upper>().rankUpdate(a.transpose());
  g.topRightCorner(p, 1).noalias() += a.transpose() * t;
  g(p, p) += t.squaredNorm();
}

// The upper triangle of the Gram matrix [Psi tau]^T [Psi tau], (p+1) x
// (p+1), in one pass over the rows: chunks of fixed length on the threads
// (blocks that stay in the cache for both products), their sums added in
// order, so that any number of threads gives the same matrix. Weighted,
// of the scaled rows, each block scaled into a buffer as it is read.
Eigen::MatrixXd augmented_gram(const Equations& reg, const RowScale& scale, unsigned threads) {
  const Eigen::Index p = reg.psi.cols();
  const Eigen::Index m = reg.psi.rows();
  constexpr Eigen::Index kBlockRows = 2048;
  const Eigen::Index chunks = row_chunks(m);
  std::vector<Eigen::MatrixXd> partial(static_cast<std::size_t>(chunks));
  const auto chunk_gram = [&](std::size_t, std::size_t chunk) {
    Eigen::MatrixXd& g = partial[chunk];
    g = Eigen::MatrixXd::Zero(p + 1, p + 1);
    Eigen::MatrixXd scaled_a;
    Eigen::VectorXd scaled_t;
    const Eigen::Index end = std::min(m, static_cast<Eigen::Index>(chunk + 1) * kRowChunk);
    for (Eigen::Index start = static_cast<Eigen::Index>(chunk) * kRowChunk; start < end;
         start += kBlockRows) {
      const Eigen::Index len = std::min(kBlockRows, end - start);
      if (scale.any()) {
        scale_rows(reg, scale, start, len, scaled_a, scaled_t);
        add_block(scaled_a, scaled_t, g);
      } else {
        add_block(reg.psi.middleRows(start, len), reg.tau.segment(start, len), g);
      }
    }
  };
  run_tasks(partial.size(), workers_for(static_cast<std::size_t>(m), threads, 60000), chunk_gram);
  Eigen::MatrixXd g = partial[0];
  for (std::size_t c = 1; c < partial.size(); ++c) g += partial[c];
  return g;
}

// The columns' norms (from the Gram matrix's diagonal), with 1 for a zero
// column (its scaled column stays zero), and the zero columns.
Eigen::VectorXd column_norms(const Eigen::MatrixXd& gram, std::vector<std::size_t>& zero_columns) {
  const Eigen::Index p = gram.cols() - 1;
  Eigen::VectorXd col_norm = gram.diagonal().head(p).cwiseSqrt();
  for (Eigen::Index c = 0; c < p; ++c) {
    if (!(col_norm(c) > 0.0)) {
      zero_columns.push_back(static_cast<std::size_t>(c));
      col_norm(c) = 1.0;
    }
  }
  return col_norm;
}

std::string names(const std::vector<std::size_t>& columns,
                  const std::vector<ParameterInfo>& parameters) {
  std::string s;
  for (const std::size_t c : columns) s += " '" + parameters[c].name + "'";
  return s;
}

// The independent columns of the scaled triangular factor rr (pivoted QR,
// a pivot below 1e-9 of the largest counts as zero) and the coefficients
// that give the dependent ones, in the parameters' own units.
Identifiability identifiability_of(const Eigen::MatrixXd& rr, const Eigen::VectorXd& col_norm,
                                   const std::vector<std::size_t>& zero_columns,
                                   const std::vector<ParameterInfo>& parameters,
                                   const std::string& log_name) {
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(rr);
  qr.setThreshold(1e-9);
  const Eigen::Index rank = qr.rank();
  const Eigen::Index p = rr.cols();
  const auto& perm = qr.colsPermutation().indices();
  // A_pivoted = Q [R11 R12; 0 ~0]: the dependent columns are A_I R11^-1 R12.
  const Eigen::MatrixXd r = qr.matrixR().topRows(rank).template triangularView<Eigen::Upper>();
  const Eigen::MatrixXd k =
      r.leftCols(rank).template triangularView<Eigen::Upper>().solve(r.rightCols(p - rank));
  Identifiability id;
  std::vector<std::pair<std::size_t, Eigen::Index>> independent, dependent;  // column, position
  for (Eigen::Index i = 0; i < p; ++i) {
    (i < rank ? independent : dependent).emplace_back(static_cast<std::size_t>(perm(i)), i);
  }
  std::sort(independent.begin(), independent.end());
  std::sort(dependent.begin(), dependent.end());
  id.coefficient.resize(rank, p - rank);
  for (std::size_t a = 0; a < independent.size(); ++a) {
    id.independent.push_back(independent[a].first);
    for (std::size_t b = 0; b < dependent.size(); ++b) {
      const auto row = static_cast<Eigen::Index>(a), col = static_cast<Eigen::Index>(b);
      // Scaled x = D beta: base_i = beta_i + K norm_d / norm_i beta_d.
      id.coefficient(row, col) = k(independent[a].second, dependent[b].second - rank) *
                                 col_norm(static_cast<Eigen::Index>(dependent[b].first)) /
                                 col_norm(static_cast<Eigen::Index>(independent[a].first));
    }
  }
  for (const auto& d : dependent) id.dependent.push_back(d.first);
  std::ostringstream s;
  s << log_name << ": the regressor is rank-deficient: this log";
  if (!zero_columns.empty()) {
    s << " does not excite" << names(zero_columns, parameters) << " at all";
  }
  std::vector<std::size_t> mixed;
  for (const std::size_t d : id.dependent) {
    if (std::find(zero_columns.begin(), zero_columns.end(), d) == zero_columns.end()) {
      mixed.push_back(d);
    }
  }
  if (!mixed.empty()) {
    s << (zero_columns.empty() ? "" : " and") << " cannot tell" << names(mixed, parameters)
      << " apart from the others";
  }
  id.message = s.str();
  return id;
}

// R of the column-scaled regressor A = Psi D^-1 = Q R, and the first p
// entries of Q^T tau, without a copy of A: blocks of rows are factored one
// after the other, each stacked under the R of those before (QR of the
// stack [R; A_block] gives the R of all the rows so far). tau rides along
// as a last column, so that the same reflections give Q^T tau.
struct TriangularFactor {
  Eigen::MatrixXd r;       // p x p, upper triangular
  Eigen::VectorXd qt_tau;  // p
};

TriangularFactor scaled_qr(const Equations& reg, const RowScale& scale,
                           const Eigen::VectorXd& col_norm) {
  const Eigen::Index p = reg.psi.cols();
  const Eigen::Index m = reg.psi.rows();
  constexpr Eigen::Index kBlockRows = 4096;
  const Eigen::RowVectorXd inverse_norm = col_norm.cwiseInverse().transpose();
  Eigen::MatrixXd stack(p + kBlockRows, p + 1);
  Eigen::MatrixXd top = Eigen::MatrixXd::Zero(p, p + 1);  // [R | Q^T tau] so far
  for (Eigen::Index start = 0; start < m; start += kBlockRows) {
    const Eigen::Index len = std::min(kBlockRows, m - start);
    const Eigen::Index above = start == 0 ? 0 : p;  // no R yet before the first block
    stack.topRows(above) = top;
    stack.block(above, 0, len, p) =
        reg.psi.middleRows(start, len).array().rowwise() * inverse_norm.array();
    stack.block(above, p, len, 1) = reg.tau.segment(start, len);
    for (Eigen::Index k = 0; k < len; ++k) {
      stack.row(above + k) *= scale.of(reg, static_cast<std::size_t>(start + k));
    }
    Eigen::Ref<Eigen::MatrixXd> rows = stack.topRows(above + len);
    Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(rows);  // in place
    top = qr.matrixQR().topRows(p).triangularView<Eigen::Upper>();
  }
  return {top.leftCols(p), top.col(p)};
}

// R and Q^T tau of the scaled regressor A = Psi D^-1 from its Gram matrix:
// R^T R = A^T A (Cholesky), Q^T tau = R^-T A^T tau. One pass over the rows
// (augmented_gram; none with JointGrams) against Householder's per column. Its rounding error
// grows with the square of the condition number, so it is taken only below
// kGramConditionLimit (at most about 1e3^2 * 1e-16 = 1e-10 of the estimate),
// and one step of refinement (refine_from_residual) takes the error down to
// Householder's; above the limit, and for rank deficiency, Householder
// (scaled_qr).
constexpr double kGramConditionLimit = 1e3;

std::optional<TriangularFactor> factor_from_gram(const Eigen::MatrixXd& gram,
                                                 const Eigen::VectorXd& col_norm) {
  const Eigen::Index p = col_norm.size();
  const Eigen::VectorXd inverse_norm = col_norm.cwiseInverse();
  const Eigen::MatrixXd full = gram.topLeftCorner(p, p).selfadjointView<Eigen::Upper>();
  const Eigen::MatrixXd scaled = inverse_norm.asDiagonal() * full * inverse_norm.asDiagonal();
  const Eigen::LLT<Eigen::MatrixXd, Eigen::Upper> llt(scaled);
  if (llt.info() != Eigen::Success) return std::nullopt;
  TriangularFactor f{llt.matrixU(), Eigen::VectorXd()};
  const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXd>(f.r).singularValues();
  if (!(sv(p - 1) * kGramConditionLimit > sv(0))) return std::nullopt;
  f.qt_tau = f.r.transpose().triangularView<Eigen::Lower>().solve(
      gram.topRightCorner(p, 1).cwiseProduct(inverse_norm));
  return f;
}

// One step of iterative refinement of the least-squares solution x = R^-1
// Q^T tau (semi-normal equations): with the residual r = tau - A x,
//   x += R^-1 R^-T A^T r,
// in one pass over the rows (each block's residual and its product with
// the block while the block is in the cache). Q^T tau becomes R x of the
// refined x, so that every solve from R (bounded ones too) sees it.
void refine_from_residual(const Equations& reg, const RowScale& scale,
                          const Eigen::VectorXd& col_norm, unsigned threads, TriangularFactor& f) {
  const Eigen::Index m = reg.psi.rows();
  constexpr Eigen::Index kBlockRows = 2048;
  const Eigen::VectorXd x = f.r.triangularView<Eigen::Upper>().solve(f.qt_tau);
  const Eigen::VectorXd beta = x.cwiseQuotient(col_norm);
  const std::array<double, 3> w = scale.weights();
  // Psi^T r per chunk of rows, the chunks added in order.
  const Eigen::Index chunks = row_chunks(m);
  std::vector<Eigen::VectorXd> partial(static_cast<std::size_t>(chunks));
  const auto chunk_product = [&](std::size_t, std::size_t chunk) {
    Eigen::VectorXd& psi_t_r = partial[chunk] = Eigen::VectorXd::Zero(x.size());
    Eigen::VectorXd r(kBlockRows);
    const Eigen::Index end = std::min(m, static_cast<Eigen::Index>(chunk + 1) * kRowChunk);
    for (Eigen::Index start = static_cast<Eigen::Index>(chunk) * kRowChunk; start < end;
         start += kBlockRows) {
      const Eigen::Index len = std::min(kBlockRows, end - start);
      const auto a = reg.psi.middleRows(start, len);
      r.head(len).noalias() = reg.tau.segment(start, len) - a * beta;
      if (scale.any()) {  // (s a)^T (s r) = a^T (w r)
        for (Eigen::Index k = 0; k < len; ++k)
          r(k) *= w[reg.joint[static_cast<std::size_t>(start + k)]];
      }
      psi_t_r.noalias() += a.transpose() * r.head(len);
    }
  };
  run_tasks(partial.size(), workers_for(static_cast<std::size_t>(m), threads, 60000),
            chunk_product);
  Eigen::VectorXd psi_t_r = partial[0];
  for (std::size_t c = 1; c < partial.size(); ++c) psi_t_r += partial[c];
  const Eigen::VectorXd y =
      f.r.transpose().triangularView<Eigen::Lower>().solve(psi_t_r.cwiseQuotient(col_norm));
  const Eigen::VectorXd step = f.r.triangularView<Eigen::Upper>().solve(y);
  f.qt_tau = f.r * (x + step);
}

// R and Q^T tau of the scaled regressor: from the Gram matrix where the
// columns are well conditioned, else by Householder QR.
TriangularFactor scaled_factor(const Equations& reg, const RowScale& scale,
                               const Eigen::MatrixXd& gram, const Eigen::VectorXd& col_norm,
                               bool any_zero_column, unsigned threads) {
  if (!any_zero_column) {
    if (std::optional<TriangularFactor> f = factor_from_gram(gram, col_norm)) {
      refine_from_residual(reg, scale, col_norm, threads, *f);
      return *f;
    }
  }
  return scaled_qr(reg, scale, col_norm);
}

// e = the scaled residual s (tau - Psi beta) of every row, on `threads`
// threads; returns |e|^2, summed per chunk of rows and the chunks added in
// order.
double scaled_residual(const Equations& r, const RowScale& scale, const Eigen::VectorXd& beta,
                       unsigned threads, Eigen::VectorXd& e) {
  const Eigen::Index m = r.psi.rows();
  const Eigen::Index chunks = row_chunks(m);
  std::vector<double> squares(static_cast<std::size_t>(chunks), 0.0);
  const auto chunk_residual = [&](std::size_t, std::size_t chunk) {
    const Eigen::Index start = static_cast<Eigen::Index>(chunk) * kRowChunk;
    const Eigen::Index len = std::min(kRowChunk, m - start);
    auto part = e.segment(start, len);
    part.noalias() = r.tau.segment(start, len) - r.psi.middleRows(start, len) * beta;
    if (scale.any()) {
      for (Eigen::Index k = 0; k < len; ++k) {
        part(k) *= scale.of(r, static_cast<std::size_t>(start + k));
      }
    }
    squares[chunk] = part.squaredNorm();
  };
  run_tasks(squares.size(), workers_for(static_cast<std::size_t>(m), threads, 60000),
            chunk_residual);
  double sum = 0.0;
  for (const double s : squares) sum += s;
  return sum;
}

// The parameters' standard deviations (Newey-West over `lags`) and the
// conditioning, from the SVD of the scaled factor and the residual e at the
// unconstrained optimum: one pass over the rows on `threads` threads.
void add_covariance(const Equations& r, const RowScale& scale,
                    const Eigen::JacobiSVD<Eigen::MatrixXd>& svd, const Eigen::MatrixXd& rr,
                    const Eigen::VectorXd& col_norm, Eigen::Ref<const Eigen::VectorXd> e,
                    std::size_t lags, unsigned threads, LeastSquaresResult& out) {
  const Eigen::Index p = r.psi.cols();
  const Eigen::Index rows = r.psi.rows();
  const Eigen::VectorXd sv = svd.singularValues();
  // (A^T A)^-1 = V Sigma^-2 V^T for the scaled regressor A = U Sigma V^T.
  const Eigen::MatrixXd vs = svd.matrixV() * sv.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd inv_ata = vs * vs.transpose();
  const double dof = rows > p ? static_cast<double>(rows) / static_cast<double>(rows - p) : 0.0;
  const Eigen::MatrixXd cov_scaled =
      dof * inv_ata * lagged_score_covariance(r, scale, col_norm, e, lags, threads) * inv_ata;
  out.std_dev = cov_scaled.diagonal().cwiseMax(0.0).cwiseSqrt().cwiseQuotient(col_norm);
  // The columns' scaling cancels in the correlations.
  const Eigen::VectorXd sd = cov_scaled.diagonal().cwiseMax(1e-300).cwiseSqrt();
  out.correlation = cov_scaled.cwiseQuotient(sd * sd.transpose());
  out.correlation_lags = lags;
  out.condition_number_scaled = sv(0) / sv(p - 1);
  // Psi = Q R D: its singular values are those of R D.
  const Eigen::VectorXd raw_sv = (rr * col_norm.asDiagonal()).jacobiSvd().singularValues();
  out.condition_number = raw_sv(0) / raw_sv(p - 1);
}

// The bounded optimum from the unconstrained one (scaled), its active
// bounds and cost.
void bound(const Equations& r, const RowScale& scale, const std::vector<ParameterInfo>& parameters,
           const Eigen::MatrixXd& rr, const Eigen::VectorXd& qt_tau,
           const Eigen::VectorXd& beta_scaled, const Eigen::VectorXd& col_norm,
           LeastSquaresResult& out) {
  const Eigen::Index p = r.psi.cols();
  // Scaling by the positive column norms keeps every bound at 0.
  std::vector<bool> nonnegative(static_cast<std::size_t>(p));
  bool inside = true;
  for (Eigen::Index c = 0; c < p; ++c) {
    nonnegative[static_cast<std::size_t>(c)] = parameters[static_cast<std::size_t>(c)].nonnegative;
    inside = inside && !(nonnegative[static_cast<std::size_t>(c)] && beta_scaled(c) < 0.0);
  }
  const Eigen::VectorXd x = inside ? beta_scaled : bounded_least_squares(rr, qt_tau, nonnegative);
  out.beta = x.cwiseQuotient(col_norm);
  for (Eigen::Index c = 0; c < p; ++c) {
    if (nonnegative[static_cast<std::size_t>(c)] && x(c) == 0.0) {
      out.active_bounds.push_back(static_cast<std::size_t>(c));
    }
  }
  out.cost = inside ? out.unconstrained_cost
                    : residual_squares(r, r.rows(), out.beta).cost(scale.weights(), r.rows());
}

// The least-squares solution from R: everything after the QR is p x p. The
// singular values and right singular vectors of R are those of the scaled
// regressor (Q has orthonormal columns).
LeastSquaresResult solve_ordinary(const Equations& r, const RowScale& scale,
                                  const std::vector<ParameterInfo>& parameters, LsSolver solver,
                                  const std::string& log_name, std::size_t lags, unsigned threads,
                                  const JointGrams* grams) {
  const Eigen::Index p = r.psi.cols();
  std::vector<std::size_t> zero_columns;
  const Eigen::MatrixXd gram =
      grams ? grams->weighted(scale.weights(), p) : augmented_gram(r, scale, threads);
  const Eigen::VectorXd col_norm = column_norms(gram, zero_columns);
  const auto [rr, qt_tau] = scaled_factor(r, scale, gram, col_norm, !zero_columns.empty(), threads);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(rr, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  if (!zero_columns.empty() || sv(p - 1) <= 1e-10 * sv(0)) {
    Identifiability id = identifiability_of(rr, col_norm, zero_columns, parameters, log_name);
    const std::string message = id.message;
    throw RankDeficientError(message, std::move(id));
  }
  const Eigen::VectorXd beta_scaled =
      solver == LsSolver::kSvd ? Eigen::VectorXd(svd.solve(qt_tau))
                               : Eigen::VectorXd(rr.triangularView<Eigen::Upper>().solve(qt_tau));
  LeastSquaresResult out;
  out.psi_t_psi = gram.topLeftCorner(p, p).selfadjointView<Eigen::Upper>();
  out.psi_t_tau = gram.topRightCorner(p, 1);
  out.tau_t_tau = gram(p, p);
  out.unconstrained_beta = beta_scaled.cwiseQuotient(col_norm);
  Eigen::VectorXd e(r.psi.rows());
  out.unconstrained_cost =
      scaled_residual(r, scale, out.unconstrained_beta, threads, e) / static_cast<double>(r.rows());
  bound(r, scale, parameters, rr, qt_tau, beta_scaled, col_norm, out);
  add_covariance(r, scale, svd, rr, col_norm, e, lags, threads, out);
  return out;
}

// The least-squares solution over the passive columns, the others at 0.
Eigen::VectorXd solve_over(const Eigen::MatrixXd& r, const Eigen::VectorXd& b,
                           const std::vector<bool>& passive) {
  std::vector<Eigen::Index> columns;
  for (Eigen::Index c = 0; c < r.cols(); ++c) {
    if (passive[static_cast<std::size_t>(c)]) columns.push_back(c);
  }
  Eigen::VectorXd z = Eigen::VectorXd::Zero(r.cols());
  if (columns.empty()) return z;
  Eigen::MatrixXd a(r.rows(), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k) {
    a.col(static_cast<Eigen::Index>(k)) = r.col(columns[k]);
  }
  const Eigen::VectorXd zp = a.householderQr().solve(b);
  for (std::size_t k = 0; k < columns.size(); ++k) {
    z(columns[k]) = zp(static_cast<Eigen::Index>(k));
  }
  return z;
}

}  // namespace

Eigen::VectorXd bounded_least_squares(const Eigen::MatrixXd& r, const Eigen::VectorXd& b,
                                      const std::vector<bool>& nonnegative) {
  const auto p = static_cast<std::size_t>(r.cols());
  std::vector<bool> passive(p);
  for (std::size_t c = 0; c < p; ++c) passive[c] = !nonnegative[c];
  // Feasible start: the free parameters' optimum with the bounded ones at 0.
  Eigen::VectorXd x = solve_over(r, b, passive);
  const double tolerance = 1e-12 * r.norm() * b.norm();
  for (std::size_t outer = 0; outer < 3 * p + 3; ++outer) {
    // The descent direction of each bounded parameter held at 0.
    const Eigen::VectorXd w = r.transpose() * (b - r * x);
    std::size_t enter = p;
    double largest = tolerance;
    for (std::size_t c = 0; c < p; ++c) {
      const auto i = static_cast<Eigen::Index>(c);
      if (!passive[c] && w(i) > largest) {
        enter = c;
        largest = w(i);
      }
    }
    if (enter == p) break;  // the KKT conditions hold
    passive[enter] = true;
    for (std::size_t inner = 0; inner <= p; ++inner) {
      const Eigen::VectorXd z = solve_over(r, b, passive);
      double step = 1.0;
      std::size_t limiting = p;
      for (std::size_t c = 0; c < p; ++c) {
        const auto i = static_cast<Eigen::Index>(c);
        if (passive[c] && nonnegative[c] && z(i) <= 0.0) {
          const double gap = x(i) - z(i);
          const double s = gap > 0.0 ? x(i) / gap : 0.0;
          if (s < step || limiting == p) {
            step = std::min(step, s);
            limiting = c;
          }
        }
      }
      if (limiting == p) {
        x = z;
        break;
      }
      // Step to the first bound met and hold the parameters there.
      x += step * (z - x);
      x(static_cast<Eigen::Index>(limiting)) = 0.0;
      for (std::size_t c = 0; c < p; ++c) {
        const auto i = static_cast<Eigen::Index>(c);
        if (passive[c] && nonnegative[c] && x(i) <= 0.0) {
          passive[c] = false;
          x(i) = 0.0;
        }
      }
    }
  }
  return x;
}

std::size_t correlation_lags_for(double sample_rate_hz, double cutoff_hz) {
  if (!(sample_rate_hz > 0.0) || !(cutoff_hz > 0.0)) return 0;
  return static_cast<std::size_t>(std::ceil(2.0 * sample_rate_hz / cutoff_hz));
}

LeastSquaresResult solve_least_squares(const Equations& r, const Model& model, LsSolver solver,
                                       LsWeights weights, const std::string& log_name,
                                       std::size_t correlation_lags, unsigned threads) {
  return solve_least_squares(r, model.parameters(), solver, weights, log_name, correlation_lags,
                             threads);
}

double bounded_least_squares_cost(const Equations& r, const std::vector<ParameterInfo>& parameters,
                                  const std::string& log_name) {
  const Eigen::Index p = r.psi.cols();
  std::vector<std::size_t> zero_columns;
  const RowScale unweighted;
  const Eigen::MatrixXd gram = augmented_gram(r, unweighted, 1);
  const Eigen::VectorXd col_norm = column_norms(gram, zero_columns);
  if (!zero_columns.empty()) {
    throw delta::InputError(log_name + ": this log does not excite" +
                            names(zero_columns, parameters) + " at all");
  }
  const auto [rr, qt_tau] = scaled_factor(r, unweighted, gram, col_norm, false, 1);
  std::vector<bool> nonnegative(static_cast<std::size_t>(p));
  for (std::size_t c = 0; c < nonnegative.size(); ++c) nonnegative[c] = parameters[c].nonnegative;
  const Eigen::VectorXd x = bounded_least_squares(rr, qt_tau, nonnegative);
  // |tau - Psi beta|^2 = |tau|^2 - |Q^T tau|^2 + |R x - Q^T tau|^2.
  const double sum = gram(p, p) - qt_tau.squaredNorm() + (rr * x - qt_tau).squaredNorm();
  return std::max(0.0, sum) / static_cast<double>(r.rows());
}

LeastSquaresResult solve_least_squares(const Equations& r,
                                       const std::vector<ParameterInfo>& parameters,
                                       LsSolver solver, LsWeights weights,
                                       const std::string& log_name, std::size_t correlation_lags,
                                       unsigned threads, const JointGrams* grams) {
  LeastSquaresResult ols =
      solve_ordinary(r, RowScale{}, parameters, solver, log_name, correlation_lags, threads, grams);
  if (weights == LsWeights::kNone) return ols;
  const ResidualSquares squares = residual_squares(r, r.rows(), ols.beta, threads);
  const std::array<std::size_t, 3> rows = r.rows_per_joint();
  std::array<double, 3> w{};
  for (unsigned j = 0; j < 3; ++j) {
    const double var = rows[j] > 0 ? squares.all[j] / static_cast<double>(rows[j]) : 0.0;
    w[j] = var > 0.0 ? 1.0 / var : 1.0;
  }
  // Normalise so the weights average to one over the joints.
  const double mean_w = (w[0] + w[1] + w[2]) / 3.0;
  for (double& x : w) x /= mean_w;
  RowScale scale;
  for (unsigned j = 0; j < 3; ++j) scale.by_joint[j] = std::sqrt(w[j]);
  LeastSquaresResult wls =
      solve_ordinary(r, scale, parameters, solver, log_name, correlation_lags, threads, grams);
  wls.joint_weights = w;
  return wls;
}

}  // namespace host_id
