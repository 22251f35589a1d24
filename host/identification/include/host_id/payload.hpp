// A payload's mass on a fitted robot (`host_id fit LOADED.csv --base
// RESULT.json`, docs/payload.md, "A payload"): with every parameter
// of the base fit held, the loaded log's torque left unexplained is
// regressed on the platform's mass columns (inertial and weight), and the
// one coefficient is the payload's mass, with its standard deviation (the
// same covariance as a fit's).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <string>

#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"
#include "host_id/preprocess.hpp"

namespace host_id {

struct PayloadResult {
  double mass_kg{0};
  double std_dev_kg{0};     // with model error (motion_spread.hpp)
  double ls_std_dev_kg{0};  // least squares' own: noise alone
  std::size_t equations{0};
  std::array<double, 3> rmse_base_Nm{};     // the base model alone, on the loaded log
  std::array<double, 3> rmse_payload_Nm{};  // with the payload
  std::string derivatives;
};

// `beta` in `model`'s order; `min_speed_rad_s` as a fit's. Throws
// InputError for paper14 (no platform mass) or a log that cannot tell the
// mass (it barely moves).
PayloadResult fit_payload(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                          const PrepareOptions& prepare, double min_speed_rad_s,
                          unsigned threads = 0);

// The base's parameters with the payload's mass added to the platform's.
Eigen::VectorXd with_payload(const Model& model, const Eigen::VectorXd& beta, double mass_kg);

// The inverse use: with a payload of known mass, each joint's torque scale
// (motor constant x gear x efficiency), which vendors often do not publish.
// The logs' torque is taken as tau_log,j = s_j tau_j: the unloaded log and
// the loaded one (the payload's mass known) together give, in one linear
// least-squares problem,
//   w_j tau_log,j - Psi_j beta = m phi_j (loaded rows), 0 (unloaded rows),
// for w_j = 1 / s_j and the robot's parameters beta in true units, where
// phi_j is the platform's mass columns (inertial and weight).
struct TorqueScaleResult {
  std::array<double, 3> scale{};         // s_j: logged torque per true torque
  std::array<double, 3> scale_std{};     // its standard deviation, with model error
  std::array<double, 3> scale_ls_std{};  // least squares' own: noise alone
  Eigen::VectorXd beta;                  // the robot's parameters, in true units
  Eigen::VectorXd beta_std;
  std::size_t equations{0};
  std::array<double, 3> rmse_Nm{};  // of the joint fit, true torque units
};
TorqueScaleResult fit_torque_scale(const Model& model, const DeltaLog& unloaded,
                                   const DeltaLog& loaded, double payload_mass_kg,
                                   const PrepareOptions& prepare, double min_speed_rad_s,
                                   unsigned threads = 0);

}  // namespace host_id
