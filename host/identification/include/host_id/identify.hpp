// One identification run: preprocess the log (preprocess.hpp), solve least
// squares (always: it is the exact reference and gives the covariance), with
// --method pso run the swarm on the same cost, and predict the fitted and
// the validation logs.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "host_id/cogging.hpp"
#include "host_id/collision_thresholds.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/model.hpp"
#include "host_id/model_support.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/pso.hpp"
#include "host_id/stribeck_signature.hpp"
#include "host_id/torque_lag.hpp"

namespace host_id {

enum class Method { kPso, kLeastSquares };

// The delta model's default for FitOptions::min_speed_rad_s. On the HIL
// chain's path1 it leaves out 14-17 % of each joint's equations and removes
// the +4..7 % bias of the viscous friction that the equations around each
// reversal leave (docs/preprocessing.md).
constexpr double kDefaultMinSpeedRadS = 0.05;

struct FitOptions {
  ModelOptions model;
  Method method{Method::kPso};
  LsSolver solver{LsSolver::kQr};
  LsWeights weights{LsWeights::kNone};
  PsoOptions pso;
  // PSO box: |beta_j| <= bound_factor * rms(tau) / rms(Psi column j), and
  // beta_j >= 0 where the physics says so.
  double bound_factor{10.0};
  PrepareOptions prepare;
  // A joint's equation at a sample where |qd| of that joint is below this is
  // left out of the estimate (not of the RMSE). Unset: kDefaultMinSpeedRadS
  // for the delta model, 0 (every sample, as in the paper) for paper14.
  std::optional<double> min_speed_rad_s;
  unsigned threads{0};
  // Search the friction's shape (the Coulomb smoothing, and the Stribeck
  // velocity where the model has a Stribeck term) by PSO, the linear
  // parameters solved exactly for each candidate (friction_shape.hpp).
  bool fit_friction_shape{false};
  // Search each joint's gearbox compliance (elasticity.hpp) and take it
  // where the held-out error says so.
  bool fit_elasticity{false};
  // Search the fit's residual for cogging where the model has no cogging
  // term (cogging.hpp; FitResult::cogging).
  bool search_cogging{true};
};

// What fit_elasticity found: each joint's compliance c = 1 / K with its
// standard deviation (Gauss-Newton, as the friction shape's), the cost and
// the held-out error rigid and elastic, and whether the log supports the
// elastic model (its held-out error lower by more than kSelectionMargin).
struct ElasticityResult {
  delta::Joint3 compliance_rad_per_Nm{};
  delta::Joint3 compliance_std{};
  bool from_arm_encoders{false};  // the log's qa1..qa3, not a search
  double cost_rigid_Nm2{0}, cost_elastic_Nm2{0};
  double held_out_rigid_Nm{0}, held_out_elastic_Nm{0};
  bool supported{false};
  std::size_t evaluations{0};
  double seconds{0};
};

// The friction shape found by fit_friction_shape, each value with its
// standard deviation (Gauss-Newton, from the same covariance as the linear
// parameters'), and the cost before and after.
struct FrictionShapeResult {
  double coulomb_smoothing_rad_s{0}, coulomb_smoothing_std{0};
  double stribeck_velocity_rad_s{0}, stribeck_velocity_std{0};  // 0: no Stribeck term
  double cost_given_Nm2{0};   // with the shape given in the options
  double cost_fitted_Nm2{0};  // with the shape found
  // Held-out torque RMSE over kSupportFolds time blocks with each shape
  // (the shape itself found on the whole log); 0 for too short a log.
  double held_out_given_Nm{0}, held_out_fitted_Nm{0};
  // The fitted shape lowers the held-out error by more than
  // kSelectionMargin: the log supports it.
  bool supported{false};
  std::size_t evaluations{0};
  double seconds{0};
};

// The minimum speed a fit with these options uses.
double min_speed_for(const FitOptions& options);

struct ParameterEstimate {
  ParameterInfo info;
  double value{0};                // the chosen method's estimate
  double ls_value{0};             // the bounded least-squares optimum
  double unconstrained_value{0};  // the least-squares optimum without bounds
  double std_dev{0};              // with model error (motion_spread.hpp)
  double ls_std_dev{0};           // from the least-squares covariance: noise alone
  double rel_std_percent{0};
  // One standard deviation of the parameter times its regressor column's
  // RMS, over the torque's RMS: how much of the torque its uncertainty
  // stands for (a near-zero parameter can have a huge rel_std and a tiny
  // share); NaN where not known.
  double std_torque_share{std::numeric_limits<double>::quiet_NaN()};
  double lower{0}, upper{0};  // the PSO bounds
  bool at_bound{false};       // held at its physical bound by the bounded optimum
  // Where the log cannot separate every parameter (FitResult::identifiability):
  // "not identifiable" (value 0, absorbed by others), or the combination
  // this value estimates ("a + 0.5 b"); empty for a parameter estimated alone.
  std::string combination;
  std::vector<std::pair<std::string, double>> combined_with;  // (parameter, coefficient)
  bool identifiable() const { return combination != "not identifiable"; }
};

// A model's torque error on one log, per joint, two ways:
//   measured: against the logged torque, noise included (what the paper's
//             Table 2 reports and what a user compares);
//   filtered: against the torque filtered like the regressor's columns,
//             the noise above the cut-off removed (the model's own error).
// Where the log carries qd and qdd nothing is filtered and the two agree.
struct LogRmse {
  std::string log;
  std::size_t samples{0};
  std::array<double, 3> rmse_measured_Nm{};
  std::array<double, 3> rmse_filtered_Nm{};
  std::array<double, 3> rms_torque_Nm{};  // the measured torque's RMS (the fit log's; else 0)
  MotionRanges ranges;                    // of the log's motion (motion_ranges.hpp)
};

// Filtered measured and predicted torques of one log under fitted
// parameters (for the plot), and its RMSE both ways.
struct Prediction {
  std::string log;
  // What the log was to the fit, for the plot: "fit", "validation", or ""
  // (host_id validate, predict: every log is held out alike).
  std::string role;
  std::vector<double> t_s;
  std::array<std::vector<double>, 3> measured_Nm, predicted_Nm;
  std::array<std::vector<double>, 3> velocity_rad_s;  // qd of each joint at each sample
  std::array<double, 3> rmse_measured_Nm{};
  std::array<double, 3> rmse_filtered_Nm{};
  MotionRanges ranges;
  LogRmse rmse() const { return {log, t_s.size(), rmse_measured_Nm, rmse_filtered_Nm, {}, ranges}; }
};

inline constexpr double kChangingRatio = 3.0;

struct FitResult {
  FitOptions options;
  delta::Geometry geometry{};  // of the fit log: the robot the parameters are for
  LogRmse fit;                 // over every sample of the fit log, slow ones included
  double min_speed_rad_s{0};
  std::array<std::size_t, 3> equations_used{};  // per joint, of fit.samples each
  std::size_t samples_in_log{0};
  std::string derivatives;
  double state_cutoff_hz{0};  // q's filter's, as used on the fit log (0: its qd, qdd columns)
  std::vector<SampleGap> gaps;
  std::size_t segments_used{0}, segments_dropped{0};
  std::vector<ParameterEstimate> parameters;
  Eigen::VectorXd beta;
  double cost_Nm2{0};     // of the chosen estimate, over the equations used
  double ls_cost_Nm2{0};  // of the least-squares optimum, likewise
  double condition_number{0};
  double condition_number_scaled{0};
  std::size_t std_dev_lags{0};  // residual correlation allowed for (least_squares.hpp)
  // The parameters' correlations from the least-squares covariance, in the
  // order of `parameters`; NaN for a parameter not identifiable on the log.
  Eigen::MatrixXd correlation;
  std::array<double, 3> joint_weights{1, 1, 1};
  std::optional<PsoResult> pso;
  // Parameters held at their physical bound (0) by the bounded optimum.
  std::vector<std::string> active_bounds;
  // Why the result cannot be trusted as it stands (poor excitation:
  // doubts_of()); empty for a sound one. Reported, not refused.
  std::vector<std::string> doubts;
  double seconds_estimator{0};
  double seconds_total{0};
  std::vector<LogRmse> validation;
  std::vector<Prediction> predictions;  // with keep_predictions: fitted log, then validation
  // Parameter name -> its truth, where the caller knows it (fit --truth).
  std::map<std::string, double> truth;
  std::optional<FrictionShapeResult> friction_shape;
  // The residual's Stribeck signature, where the model has no Stribeck
  // term (stribeck_signature.hpp).
  std::optional<StribeckSignature> stribeck;
  // Parameters that change along the log (runs glued together, a drift):
  // their spread over its spans of time, kChangingRatio or more times that
  // over any split of its motions (motion_spread.hpp); the largest ratio.
  std::vector<std::string> changing;
  double changing_ratio{0};
  std::optional<ElasticityResult> elasticity;
  // Which variant the log supports, judged on the fit's own rows (delta and
  // lumped, long enough logs): model_selection.hpp's judge_support().
  std::optional<ModelSelection> support;
  // Set where the log cannot separate every parameter: the estimate is of
  // the base parameters (least_squares.hpp).
  std::optional<Identifiability> identifiability;
  // The collision detector's thresholds for this model
  // (collision_thresholds.hpp), or why there are none.
  std::optional<CollisionThresholdFit> collision;
  std::string collision_unavailable;
  // The logged torque's lag behind the motion (torque_lag.hpp).
  std::optional<TorqueLag> torque_lag;
  // Cogging in the residual of a model without the term (cogging.hpp); a
  // fit with the term carries the search that found it (fit --model auto)
  // and its held-out judgement.
  std::optional<CoggingSearch> cogging;
  std::optional<CoggingSupport> cogging_support;
};

// Fits log; result.validation gets the RMSE of each validation log. With
// keep_predictions, result.predictions holds the measured and predicted
// torques of the fitted log and then of each validation log (for a plot).
// Every log is preprocessed once.
// The log is taken by value: a caller that moves it in lets the fit free
// its samples once they are preprocessed (the CLI does, for a long log's
// memory).
// PSO searches the same bounded problem that least squares solves exactly:
// a swarm that stops more than this (relative) above that optimum has not
// found it, and fit_log refuses its result rather than report it.
// A fit is doubtful (FitResult::doubts) where the scaled condition number
// passes kConditionDoubt (good excitations: about 30), where a parameter's
// uncertainty stands for more than kStdShareDoubt of the torque
// (ParameterEstimate::std_torque_share), or where kPinnedDoubt or more
// parameters sit at their bounds; and where the log supports another
// variant (FitResult::support) whose held-out error is kSupportDoubt or
// more below the fitted one's.
inline constexpr double kConditionDoubt = 1e3;
inline constexpr double kStdShareDoubt = 0.1;
inline constexpr std::size_t kPinnedDoubt = 3;
inline constexpr double kSupportDoubt = 0.1;
inline constexpr unsigned kSupportFolds = 5;
std::vector<std::string> doubts_of(const FitResult& r);

// Torques of the sign opposite to docs/conventions.md's are refused: where
// parameters sit at their bounds and the bounded fit of -tau costs less
// than kSignFlipRatio times that of tau.
inline constexpr double kSignFlipRatio = 0.25;

inline constexpr double kPsoOptimumTolerance = 1e-6;
class PsoShortOfOptimumError : public delta::InputError {
 public:
  using delta::InputError::InputError;
};
// Throws PsoShortOfOptimumError naming the gap and the remedies when r's
// PSO cost is above its least-squares cost by more than the tolerance.
void require_pso_at_optimum(const FitResult& r, const std::string& log_name);

FitResult fit_log(DeltaLog log, const FitOptions& options,
                  const std::vector<const DeltaLog*>& validation = {},
                  bool keep_predictions = false);

Prediction predict(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                   const PrepareOptions& prepare, unsigned threads);

}  // namespace host_id
