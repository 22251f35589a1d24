#include "host_id/model_selection.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <span>
#include <sstream>
#include <stdexcept>

#include "delta/input_error.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/parallel.hpp"
#include "host_id/preprocess.hpp"

namespace host_id {

namespace {

// Each fold's moments of the superset's rows: sum psi psi^T, psi tau, tau^2.
struct FoldMoments {
  Eigen::MatrixXd gram;
  Eigen::VectorXd psi_tau;
  double tau_tau{0};
  std::size_t rows{0};
};

std::vector<FoldMoments> fold_moments(const Regression& all, std::size_t rows, unsigned folds) {
  const Eigen::Index p = all.psi.cols();
  std::vector<FoldMoments> m(folds);
  for (FoldMoments& f : m) {
    f.gram = Eigen::MatrixXd::Zero(p, p);
    f.psi_tau = Eigen::VectorXd::Zero(p);
  }
  // Rows go into the fold of their sample's time block.
  std::vector<std::vector<Eigen::Index>> members(folds);
  const std::size_t samples = all.samples();
  for (std::size_t r = 0; r < rows; ++r) {
    members[all.sample[r] * folds / samples].push_back(static_cast<Eigen::Index>(r));
  }
  for (unsigned f = 0; f < folds; ++f) {
    const Eigen::MatrixXd psi = all.psi(members[f], Eigen::all);
    const Eigen::VectorXd tau = all.tau(members[f]);
    m[f].gram = psi.transpose() * psi;
    m[f].psi_tau = psi.transpose() * tau;
    m[f].tau_tau = tau.squaredNorm();
    m[f].rows = members[f].size();
  }
  return m;
}

// The superset's columns each of a variant's parameters sums: its own name,
// or its per-joint names (NAME_1..NAME_3) where the superset has those.
Eigen::MatrixXd column_map(const Model& superset, const Model& variant) {
  const auto& big = superset.parameters();
  const auto& small = variant.parameters();
  Eigen::MatrixXd map = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(big.size()),
                                              static_cast<Eigen::Index>(small.size()));
  for (std::size_t c = 0; c < small.size(); ++c) {
    bool found = false;
    for (std::size_t b = 0; b < big.size(); ++b) {
      const std::string& n = big[b].name;
      const std::string& s = small[c].name;
      const bool same = n == s;
      const bool joint_of = n.size() == s.size() + 2 && n.compare(0, s.size(), s) == 0 &&
                            n[s.size()] == '_' && n[s.size() + 1] >= '1' && n[s.size() + 1] <= '3';
      if (same || joint_of) {
        map(static_cast<Eigen::Index>(b), static_cast<Eigen::Index>(c)) = 1.0;
        found = true;
      }
    }
    if (!found) throw std::logic_error("model selection: no column for " + small[c].name);
  }
  return map;
}

// The held-out squared error of a variant over every fold: trained on the
// other folds' moments by bounded least squares.
double held_out_sse(const std::vector<FoldMoments>& folds, const Eigen::MatrixXd& map,
                    const std::vector<bool>& nonnegative) {
  const Eigen::Index p = map.cols();
  FoldMoments total{Eigen::MatrixXd::Zero(p, p), Eigen::VectorXd::Zero(p), 0, 0};
  std::vector<FoldMoments> mapped;
  for (const FoldMoments& f : folds) {
    mapped.push_back(
        {map.transpose() * f.gram * map, map.transpose() * f.psi_tau, f.tau_tau, f.rows});
    total.gram += mapped.back().gram;
    total.psi_tau += mapped.back().psi_tau;
  }
  double sse = 0;
  for (const FoldMoments& f : mapped) {
    const Eigen::MatrixXd g = total.gram - f.gram;
    const Eigen::LLT<Eigen::MatrixXd> llt(g);
    if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
    const Eigen::MatrixXd upper = llt.matrixU();
    const Eigen::VectorXd beta =
        bounded_least_squares(upper, llt.matrixL().solve(total.psi_tau - f.psi_tau), nonnegative);
    sse += f.tau_tau - 2.0 * beta.dot(f.psi_tau) + beta.dot(f.gram * beta);
  }
  return sse;
}

std::string variant_name(const ModelOptions& m) {
  return std::string(m.per_joint ? "per-joint arms" : "shared arms") +
         (m.offsets ? ", torque offsets" : "") + (m.torque_gains ? ", torque gains" : "") +
         (m.load_friction ? ", load friction" : "");
}

// Whether variant x's held-out error is below y's by more than the margin.
bool lowers_by(const ModelSelection& s, std::size_t x, std::size_t y, double margin) {
  return s.variants[x].held_out_rmse_Nm < s.variants[y].held_out_rmse_Nm * (1.0 - margin);
}

// One variant's held-out error from the superset's fold moments.
VariantScore score_variant(const std::vector<FoldMoments>& moments, const Model& superset,
                           const ModelOptions& m, std::size_t rows) {
  const auto variant = make_model(m);
  std::vector<bool> nonnegative;
  for (const ParameterInfo& p : variant->parameters()) nonnegative.push_back(p.nonnegative);
  const double sse = held_out_sse(moments, column_map(superset, *variant), nonnegative);
  return {variant_name(m), m, variant->size(), std::sqrt(sse / static_cast<double>(rows))};
}

// The arms and offsets: per-joint arms first (physics the shared model
// lacks), then torque offsets on top of the arms chosen; the first four
// variants.
void choose_arms_and_offsets(ModelSelection& out,
                             const std::function<bool(std::size_t, std::size_t)>& better) {
  const std::size_t arms = better(1, 0) ? 1 : 0;
  const std::size_t with_offsets = arms == 1 ? 3 : 2;
  out.chosen = better(with_offsets, arms) ? with_offsets : arms;
  // With offsets in, per-joint arms must still pay their way.
  if (out.chosen == 3 && !better(3, 2)) out.chosen = 2;
  // Per-joint arms and offsets alone can explain a log alike (over a small
  // joint range, a per-joint gravity moment is nearly a constant).
  const std::size_t other = out.chosen == 1 ? 2 : out.chosen == 2 ? 1 : 0;
  if (other != 0 && !better(out.chosen, other) && !better(other, out.chosen)) {
    out.alike = out.variants[other].name;
  }
}

// The drive train's terms on top of the arms and offsets chosen: torque
// gains, load friction, both; each taken where it lowers the held-out
// error by kDriveTrainMargin against the arms and offsets chosen (both:
// that, and the usual margin against either alone).
void choose_drive_train(ModelSelection& out, const std::vector<FoldMoments>& moments,
                        const Model& superset, std::size_t rows,
                        const std::function<bool(std::size_t, std::size_t)>& better) {
  const ModelOptions arms = out.variants[out.chosen].model;
  for (const auto& [gains, load] : {std::pair{true, false}, {false, true}, {true, true}}) {
    ModelOptions m = arms;
    m.torque_gains = gains;
    m.load_friction = load;
    out.variants.push_back(score_variant(moments, superset, m, rows));
  }
  const auto clearly_better = [&](std::size_t x, std::size_t y) {
    return lowers_by(out, x, y, kDriveTrainMargin);
  };
  const std::size_t first = out.variants.size() - 3;
  const std::size_t base = out.chosen;
  for (std::size_t v = first; v < first + 2; ++v) {
    if (clearly_better(v, base) && (out.chosen == base || better(v, out.chosen))) out.chosen = v;
  }
  // Both terms: against the arms and offsets as each alone, and each must
  // still pay its way on top of the other.
  const std::size_t both = first + 2;
  if (clearly_better(both, base) && better(both, first) && better(both, first + 1)) {
    out.chosen = both;
  }
}

// The variants' held-out errors from the superset's fold moments, and the
// choice among them (choose_arms_and_offsets, then choose_drive_train).
ModelSelection choose_variant(const std::vector<FoldMoments>& moments, const Model& superset,
                              const ModelOptions& base, unsigned folds) {
  ModelSelection out;
  out.folds = folds;
  std::size_t rows = 0;
  for (const FoldMoments& f : moments) rows += f.rows;
  // shared arms, per-joint arms, shared arms with offsets, both
  for (const bool offsets : {false, true}) {
    for (const bool per_joint : {false, true}) {
      ModelOptions m = base;
      m.per_joint = per_joint;
      m.offsets = offsets;
      m.load_friction = false;
      m.torque_gains = false;
      out.variants.push_back(score_variant(moments, superset, m, rows));
    }
  }
  const auto better = [&](std::size_t x, std::size_t y) {
    return lowers_by(out, x, y, kSelectionMargin);
  };
  choose_arms_and_offsets(out, better);
  choose_drive_train(out, moments, superset, rows, better);
  std::ostringstream why;
  why << out.variants[out.chosen].name << ": held-out torque error "
      << out.variants[out.chosen].held_out_rmse_Nm << " N m RMS over " << folds
      << " time blocks of the log; per-joint arms, then torque offsets, then the drive train's "
         "torque gains and load friction, are taken only where they lower it by more than "
      << 100.0 * kSelectionMargin << " % (the drive train's: " << 100.0 * kDriveTrainMargin
      << " %)";
  if (!out.alike.empty()) {
    why << "; " << out.alike << " explain the log as well: a log with wider joint swings tells "
        << "them apart";
  }
  out.reason = why.str();
  return out;
}

// Each fold's and joint's moments of a fit's rows z = (psi, 1, load, tau)
// and tau, gathered a chunk of rows at a time (no copy of the regression).
// The constant stands for a torque offset, tau for a torque gain, and load
// = |tau| tanh(qd / w) for load friction, all in the filtered torque: a
// variant the fit lacks is judged from them (the fit that takes it then
// writes its columns from the measured torque, before filtering).
struct BlockMoments {
  Eigen::MatrixXd zz;
  Eigen::VectorXd z_tau;
  double tau_tau{0};
  std::size_t rows{0};
};

// Where the extra columns of z sit after psi's p columns.
constexpr Eigen::Index kConstantAfter = 0, kLoadAfter = 1, kTauAfter = 2, kExtraColumns = 3;

// Each joint's own columns (the others are zero in its rows), then the
// constant, load and tau.
std::array<std::vector<Eigen::Index>, 3> own_columns(const Regression& r) {
  const Eigen::Index p = r.psi.cols();
  std::array<std::vector<Eigen::Index>, 3> own;
  for (unsigned j = 0; j < 3; ++j) {
    if (!r.joint_columns[j].empty() && r.joint_columns_of == p) {
      own[j] = r.joint_columns[j];
    } else {
      for (Eigen::Index c = 0; c < p; ++c) own[j].push_back(c);
    }
    for (Eigen::Index e = 0; e < kExtraColumns; ++e) own[j].push_back(p + e);
  }
  return own;
}

// The moments of rows [first, end) of one fold, a chunk of consecutive
// rows at a time: a chunk's columns are contiguous in psi (column-major),
// and each joint's rows are gathered from its copy.
void fold_block_moments(const Regression& r, std::size_t first, std::size_t end,
                        const std::array<std::vector<Eigen::Index>, 3>& own,
                        double load_smoothing_rad_s, BlockMoments* joint_blocks) {
  const Eigen::Index p = r.psi.cols(), q = p + kExtraColumns;
  constexpr Eigen::Index kChunk = 1024;
  Eigen::MatrixXd chunk(kChunk, q), joint_rows(kChunk, q);
  std::array<Eigen::MatrixXd, 3> sums;  // over each joint's own columns
  for (unsigned j = 0; j < 3; ++j) {
    const auto k = static_cast<Eigen::Index>(own[j].size());
    sums[j] = Eigen::MatrixXd::Zero(k, k);
  }
  std::vector<Eigen::Index> members;
  for (std::size_t from = first; from < end;) {
    const std::size_t to = std::min(end, from + static_cast<std::size_t>(kChunk));
    const auto n = static_cast<Eigen::Index>(to - from);
    const auto at = static_cast<Eigen::Index>(from);
    chunk.topLeftCorner(n, p) = r.psi.middleRows(at, n);
    chunk.col(p + kConstantAfter).head(n).setOnes();
    chunk.col(p + kTauAfter).head(n) = r.tau.segment(at, n);
    for (Eigen::Index i = 0; i < n; ++i) {
      chunk(i, p + kLoadAfter) =
          std::abs(r.tau(at + i)) *
          std::tanh(r.velocity_rad_s[static_cast<std::size_t>(at + i)] / load_smoothing_rad_s);
    }
    for (unsigned j = 0; j < 3; ++j) {
      members.clear();
      for (std::size_t i = from; i < to; ++i) {
        if (r.joint[i] == j) members.push_back(static_cast<Eigen::Index>(i - from));
      }
      if (members.empty()) continue;
      const auto m = static_cast<Eigen::Index>(members.size());
      const auto k = static_cast<Eigen::Index>(own[j].size());
      // (Spans: an indexed view keeps a copy of a vector of indices.)
      joint_rows.topLeftCorner(m, k) =
          chunk(std::span<const Eigen::Index>(members), std::span<const Eigen::Index>(own[j]));
      sums[j].selfadjointView<Eigen::Lower>().rankUpdate(
          joint_rows.topLeftCorner(m, k).transpose());
      joint_blocks[j].rows += members.size();
    }
    from = to;
  }
  for (unsigned j = 0; j < 3; ++j) {
    BlockMoments& b = joint_blocks[j];
    b.zz = Eigen::MatrixXd::Zero(q, q);
    b.z_tau = Eigen::VectorXd::Zero(q);
    const auto k = static_cast<Eigen::Index>(own[j].size());
    const Eigen::MatrixXd full = sums[j].selfadjointView<Eigen::Lower>();
    for (Eigen::Index x = 0; x < k; ++x) {
      const Eigen::Index cx = own[j][static_cast<std::size_t>(x)];
      for (Eigen::Index y = 0; y < k; ++y) {
        b.zz(cx, own[j][static_cast<std::size_t>(y)]) = full(x, y);
      }
      b.z_tau(cx) = full(x, k - 1);
    }
    b.tau_tau = full(k - 1, k - 1);
  }
}

std::vector<BlockMoments> block_moments(const Regression& r, std::size_t rows, unsigned folds,
                                        double load_smoothing_rad_s, unsigned threads) {
  // The folds' row ranges: the fast rows are in time order.
  const std::size_t samples = r.samples();
  std::vector<std::size_t> bounds(folds + 1, rows);
  bounds[0] = 0;
  for (std::size_t i = 0, f = 1; i < rows && f < folds; ++i) {
    while (f < folds && r.sample[i] * folds / samples >= f) bounds[f++] = i;
  }
  const auto own = own_columns(r);
  // Each fold in two halves, so that two threads share an odd number of
  // folds evenly; the halves' sums are added in order.
  std::vector<BlockMoments> halves(6 * folds);
  run_tasks(2 * folds, workers_for(rows, threads, 60000), [&](std::size_t, std::size_t h) {
    const std::size_t f = h / 2, middle = (bounds[f] + bounds[f + 1]) / 2;
    const std::size_t first = h % 2 == 0 ? bounds[f] : middle;
    const std::size_t end = h % 2 == 0 ? middle : bounds[f + 1];
    fold_block_moments(r, first, end, own, load_smoothing_rad_s, &halves[3 * h]);
  });
  std::vector<BlockMoments> blocks(3 * folds);
  for (std::size_t f = 0; f < folds; ++f) {
    for (unsigned j = 0; j < 3; ++j) {
      BlockMoments& b = blocks[3 * f + j];
      b = halves[6 * f + j];
      const BlockMoments& second = halves[6 * f + 3 + j];
      b.zz += second.zz;
      b.z_tau += second.z_tau;
      b.tau_tau += second.tau_tau;
      b.rows += second.rows;
    }
  }
  return blocks;
}

// Each joint's Gram matrix of [Psi tau] over all the blocks, from the
// blocks' moments of z = [Psi 1 load tau].
JointGrams joint_grams(const std::vector<BlockMoments>& blocks, Eigen::Index p) {
  std::vector<Eigen::Index> psi_and_tau(static_cast<std::size_t>(p) + 1);
  for (Eigen::Index c = 0; c < p; ++c) psi_and_tau[static_cast<std::size_t>(c)] = c;
  psi_and_tau.back() = p + kTauAfter;
  JointGrams out;
  for (unsigned j = 0; j < 3; ++j) out.of_joint[j] = Eigen::MatrixXd::Zero(p + 1, p + 1);
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    out.of_joint[b % 3] += blocks[b].zz(psi_and_tau, psi_and_tau);
  }
  return out;
}

// Where each of the superset's parameters comes from in a fitted model's
// rows: a column of z (the constant, load or tau for a term the fit lacks)
// and the joints whose rows it is taken in.
struct Source {
  Eigen::Index column;
  std::array<bool, 3> joints;
};

std::vector<Source> sources(const Model& superset, const Model& fitted) {
  const auto& big = superset.parameters();
  const auto& own = fitted.parameters();
  const auto find = [&](const std::string& name) -> Eigen::Index {
    for (std::size_t c = 0; c < own.size(); ++c) {
      if (own[c].name == name) return static_cast<Eigen::Index>(c);
    }
    return -1;
  };
  std::vector<Source> out;
  for (const ParameterInfo& p : big) {
    if (const Eigen::Index c = find(p.name); c >= 0) {
      out.push_back({c, {true, true, true}});
      continue;
    }
    // NAME_j: the fit's shared NAME in joint j's rows, or (a torque offset
    // it lacks) the constant 1 there.
    const std::string& n = p.name;
    const int j = n.size() > 2 && n[n.size() - 2] == '_' ? n.back() - '1' : -1;
    if (j < 0 || j > 2) throw std::logic_error("model support: no column for " + n);
    const std::string base = n.substr(0, n.size() - 2);
    Eigen::Index c = find(base);
    const auto psi_columns = static_cast<Eigen::Index>(own.size());
    if (c < 0 && base == "torque_offset") c = psi_columns + kConstantAfter;
    if (c < 0 && base == "load_friction") c = psi_columns + kLoadAfter;
    if (c < 0 && base == "torque_gain_gap") c = psi_columns + kTauAfter;
    if (c < 0) throw std::logic_error("model support: no column for " + n);
    std::array<bool, 3> joints{};
    joints[static_cast<std::size_t>(j)] = true;
    out.push_back({c, joints});
  }
  return out;
}

// Each fold's moments of the columns `src` names, from the folds' and
// joints' moments of the fitted rows.
std::vector<FoldMoments> moments_from_blocks(const std::vector<BlockMoments>& blocks,
                                             const std::vector<Source>& src, unsigned folds) {
  const auto p = static_cast<Eigen::Index>(src.size());
  std::vector<FoldMoments> moments(folds);
  for (unsigned f = 0; f < folds; ++f) {
    FoldMoments& m = moments[f];
    m.gram = Eigen::MatrixXd::Zero(p, p);
    m.psi_tau = Eigen::VectorXd::Zero(p);
    for (std::size_t j = 0; j < 3; ++j) {
      const BlockMoments& b = blocks[f * 3 + j];
      m.tau_tau += b.tau_tau;
      m.rows += b.rows;
      for (Eigen::Index x = 0; x < p; ++x) {
        const Source& sx = src[static_cast<std::size_t>(x)];
        if (!sx.joints[j]) continue;
        m.psi_tau(x) += b.z_tau(sx.column);
        for (Eigen::Index y = 0; y < p; ++y) {
          const Source& sy = src[static_cast<std::size_t>(y)];
          if (sy.joints[j]) m.gram(x, y) += b.zz(sx.column, sy.column);
        }
      }
    }
  }
  return moments;
}

}  // namespace

ModelSelection select_model(const DeltaLog& log, const FitOptions& options, unsigned folds) {
  if (options.model.name == "paper14") {
    throw delta::InputError(
        "--model auto chooses among the delta and lumped models' variants; "
        "paper14 has none");
  }
  ModelOptions largest = options.model;
  largest.per_joint = true;
  largest.offsets = true;
  largest.load_friction = true;
  largest.torque_gains = true;
  const auto superset = make_model(largest);
  PrepareOptions prepare = options.prepare;
  prepare.slow_rows_last_below_rad_s = min_speed_for(options);
  const Preprocessed pre = preprocess(*superset, log, prepare, options.threads);
  if (pre.regression.samples() < 20 * folds) {
    throw delta::InputError(log.name + ": too short to judge the model on " +
                            std::to_string(folds) + " time blocks");
  }
  return choose_variant(fold_moments(pre.regression, pre.fast_rows, folds), *superset,
                        options.model, folds);
}

ModelSelection judge_support(const Model& fitted, const ModelOptions& fitted_options,
                             const Regression& r, std::size_t rows, unsigned folds,
                             unsigned threads, JointGrams* grams) {
  if (fitted_options.name == "paper14") {
    throw delta::InputError("paper14 has no variants to judge");
  }
  if (r.samples() < 20 * folds) {
    throw delta::InputError("too short to judge the model on " + std::to_string(folds) +
                            " time blocks");
  }
  ModelOptions largest = fitted_options;
  largest.per_joint = true;
  largest.offsets = true;
  largest.load_friction = true;
  largest.torque_gains = true;
  const auto superset = make_model(largest);
  const std::vector<Source> src = sources(*superset, fitted);
  const std::vector<BlockMoments> blocks =
      block_moments(r, rows, folds, fitted_options.coulomb_smoothing_rad_s, threads);
  if (grams) *grams = joint_grams(blocks, r.psi.cols());
  const std::vector<FoldMoments> moments = moments_from_blocks(blocks, src, folds);
  ModelOptions base = fitted_options;
  base.per_joint = false;
  base.offsets = false;
  base.load_friction = false;
  base.torque_gains = false;
  ModelSelection out = choose_variant(moments, *superset, base, folds);
  // The variant fitted is scored too where the choice did not try it.
  if (variant_index(out, fitted_options) == out.variants.size()) {
    std::size_t rows_in_folds = 0;
    for (const FoldMoments& f : moments) rows_in_folds += f.rows;
    out.variants.push_back(score_variant(moments, *superset, fitted_options, rows_in_folds));
  }
  return out;
}

double held_out_rmse(const Model& model, const Regression& r, std::size_t rows, unsigned folds,
                     unsigned threads, const std::vector<std::size_t>& left_out) {
  if (r.samples() < 20 * folds) {
    throw delta::InputError("too short to judge the model on " + std::to_string(folds) +
                            " time blocks");
  }
  const auto p = static_cast<Eigen::Index>(model.size());
  std::vector<Source> own;  // every column as it is
  for (Eigen::Index c = 0; c < p; ++c) own.push_back({c, {true, true, true}});
  const std::vector<FoldMoments> moments = moments_from_blocks(
      block_moments(r, rows, folds, model.options().coulomb_smoothing_rad_s, threads), own, folds);
  std::size_t all_rows = 0;
  for (const FoldMoments& m : moments) all_rows += m.rows;
  // The columns kept, each its own parameter.
  std::vector<bool> nonnegative;
  std::vector<Eigen::Index> kept;
  for (std::size_t c = 0; c < model.size(); ++c) {
    if (std::find(left_out.begin(), left_out.end(), c) != left_out.end()) continue;
    kept.push_back(static_cast<Eigen::Index>(c));
    nonnegative.push_back(model.parameters()[c].nonnegative);
  }
  Eigen::MatrixXd map = Eigen::MatrixXd::Zero(p, static_cast<Eigen::Index>(kept.size()));
  for (std::size_t k = 0; k < kept.size(); ++k) map(kept[k], static_cast<Eigen::Index>(k)) = 1.0;
  const double sse = held_out_sse(moments, map, nonnegative);
  return std::sqrt(sse / static_cast<double>(all_rows));
}

}  // namespace host_id
