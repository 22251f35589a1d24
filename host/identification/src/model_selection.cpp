#include "host_id/model_selection.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "delta/input_error.hpp"
#include "host_id/least_squares.hpp"
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
         (m.offsets ? ", torque offsets" : "");
}

}  // namespace

ModelSelection select_model(const DeltaLog& log, const FitOptions& options, unsigned folds) {
  if (options.model.name == "paper14") {
    throw delta::InputError(
        "--model auto chooses among the delta and lumped models' variants; "
        "paper14 has none");
  }
  ModelSelection out;
  out.folds = folds;
  ModelOptions largest = options.model;
  largest.per_joint = true;
  largest.offsets = true;
  const auto superset = make_model(largest);
  PrepareOptions prepare = options.prepare;
  prepare.slow_rows_last_below_rad_s = min_speed_for(options);
  const Preprocessed pre = preprocess(*superset, log, prepare, options.threads);
  if (pre.regression.samples() < 20 * folds) {
    throw delta::InputError(log.name + ": too short to judge the model on " +
                            std::to_string(folds) + " time blocks");
  }
  const std::vector<FoldMoments> moments = fold_moments(pre.regression, pre.fast_rows, folds);
  std::size_t rows = 0;
  for (const FoldMoments& f : moments) rows += f.rows;
  // shared arms, per-joint arms, shared arms with offsets, both
  for (const bool offsets : {false, true}) {
    for (const bool per_joint : {false, true}) {
      ModelOptions m = options.model;
      m.per_joint = per_joint;
      m.offsets = offsets;
      const auto variant = make_model(m);
      std::vector<bool> nonnegative;
      for (const ParameterInfo& p : variant->parameters()) nonnegative.push_back(p.nonnegative);
      const double sse = held_out_sse(moments, column_map(*superset, *variant), nonnegative);
      out.variants.push_back(
          {variant_name(m), m, variant->size(), std::sqrt(sse / static_cast<double>(rows))});
    }
  }
  // variants: shared, per-joint, offsets, both (the loops' order). The
  // arms first (per-joint arms are physics the shared model lacks), then
  // torque offsets on top of the arms chosen; each must lower the held-out
  // error by more than the margin.
  const auto better = [&](std::size_t x, std::size_t y) {
    return out.variants[x].held_out_rmse_Nm <
           out.variants[y].held_out_rmse_Nm * (1.0 - kSelectionMargin);
  };
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
  std::ostringstream why;
  why << out.variants[out.chosen].name << ": held-out torque error "
      << out.variants[out.chosen].held_out_rmse_Nm << " N m RMS over " << folds
      << " time blocks of the log; per-joint arms, then torque offsets, are taken only where they "
         "lower it by more than "
      << 100.0 * kSelectionMargin << " %";
  if (!out.alike.empty()) {
    why << "; " << out.alike << " explain the log as well: a log with wider joint swings tells "
        << "them apart";
  }
  out.reason = why.str();
  return out;
}

}  // namespace host_id
