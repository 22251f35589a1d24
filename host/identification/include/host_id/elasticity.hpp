// Elastic gearboxes (`host_id fit --elastic`, docs/model.md, "Elastic
// gearboxes"). The encoder sits on the motor, so the logged angle is the
// motor side's, θ_m; the arm is at q_a = θ_m − c τ_gear, c = 1 / K the
// gearbox's compliance. The fit takes the gear's torque as the model's own
// without the joint's friction, which acts on the motor's side (the
// rotor's inertia, a small part of it, is left in) and fits the arm's
// dynamics at q_a: the model stays linear in
// its parameters for a given c, and c (one per joint) is searched by PSO
// with the linear parameters solved exactly for each candidate (variable
// projection). A prediction has no measured torque: it solves for its own
// (arm_side_for_prediction).
#pragma once

#include <array>
#include <cstddef>

#include "delta/dynamics.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"

namespace host_id {

// The search box, rad/(N m): rigid (0) to a stiffness of 100 N m/rad, as
// soft as a belt reduction (a strain-wave gearbox at a delta's joint is a
// few thousand). A stiffness found at the bound is a doubt (fit_doubts):
// the drive train is softer than the search covers, or the log explains
// something else by it.
constexpr double kComplianceMaxRadPerNm = 1.0 / 100.0;

// The log with the arm's angle q_j − c_j τ_j, τ the given torque (the
// logged one, or a prediction). Throws delta::InputError for a log with qd
// and qdd columns (the motor's; the arm's need q differentiated).
void to_arm_side(DeltaLog& log, const delta::Joint3& compliance_rad_per_Nm, const Series3& tau_Nm);

// Whether the log has the arm side's encoders, columns qa1..qa3
// (docs/log-format.md); and the log with q replaced by them.
bool has_arm_encoders(const DeltaLog& log);
void to_logged_arm_side(DeltaLog& log);

// The torque a deflection is taken from: `model`'s own at the log's angles
// (not the measured torque, whose noise the deflection's second derivative
// would explain), at every sample (a trimmed one the nearest kept one's),
// low-pass filtered at the fit's cut-off (prepare.cutoff_hz), below any
// gearbox's resonance with the arm.
Series3 deflection_torque(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                          const PrepareOptions& prepare);

// The arm-side log a prediction of `model` (an elastic one) uses: q − c τ̂,
// τ̂ the model's own torque at the arm's angle (deflection_torque), found by
// fixed-point iteration from θ_m (kArmSidePasses passes; the deflection is
// a few mrad, and each pass shrinks its error by (f / f_resonance)^2 within
// the filter's band). Where the log has qa1..qa3, those.
constexpr int kArmSidePasses = 2;
DeltaLog arm_side_for_prediction(const Model& model, const Eigen::VectorXd& beta,
                                 const DeltaLog& log, const PrepareOptions& prepare);

// Throws delta::InputError as fit_log does, and for paper14 or a log with
// qd and qdd columns.
ElasticityResult fit_elasticity(const DeltaLog& log, const FitOptions& options);

}  // namespace host_id
