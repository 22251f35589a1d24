// A payload's mass on a fitted robot (`host_id fit LOADED.csv --base
// RESULT.json`, docs/identification.md, "A payload"): with every parameter
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
  double std_dev_kg{0};
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

}  // namespace host_id
