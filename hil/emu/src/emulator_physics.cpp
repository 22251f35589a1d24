// The emulated drives' physics: the current loop and its measurement, the
// encoders' counts, and the plant advanced between SYNCs.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "delta/can/protocol.hpp"
#include "emu/emulator.hpp"

namespace emu {

namespace p = delta::can::protocol;
namespace od = delta::can::od;
namespace sdo = delta::can::sdo;
namespace cia = delta::can::cia402;
using delta::can::Frame;

namespace {}  // namespace

std::int32_t Emulator::position_counts(const Drive& d, double q) const {
  const double motor_revs =
      (q - d.model.joint_zero_rad) / (2.0 * std::numbers::pi) * d.model.gear_ratio;
  const double counts = std::round(motor_revs * d.model.counts_per_rev);
  return static_cast<std::int32_t>(d.model.inverted ? -counts : counts);
}

double Emulator::joint_angle_rad(const Drive& d, std::int32_t counts) const {
  const double c = d.model.inverted ? -static_cast<double>(counts) : static_cast<double>(counts);
  return c / d.model.counts_per_rev / d.model.gear_ratio * 2.0 * std::numbers::pi +
         d.model.joint_zero_rad;
}

std::int32_t Emulator::velocity_counts_s(const Drive& d, double qd) const {
  const double counts_s =
      qd / (2.0 * std::numbers::pi) * d.model.gear_ratio * d.model.counts_per_rev;
  return static_cast<std::int32_t>((d.model.inverted ? -1 : 1) * std::llround(counts_s));
}

void Emulator::advance(double dt_s) {
  bool all_enabled = true;
  for (const Drive& d : drives_)
    all_enabled = all_enabled && d.state == cia::State::kOperationEnabled;
  const int n =
      config_.substeps > 0 ? config_.substeps : (config_.plant == PlantKind::kMujoco ? 2 : 8);
  const double h = dt_s / n;
  const double decay = std::exp(-h / config_.current_time_constant_s);
  // The mean of the first-order response over a sub-step, as a fraction of
  // its start's distance from the target: (T/h)(1 - exp(-h/T)).
  const double mean_share = config_.current_time_constant_s / h * (1.0 - decay);
  for (int s = 0; s < n; ++s) {
    delta::Joint3 tau{};
    for (unsigned j = 0; j < 3; ++j) {
      Drive& d = drives_[j];
      const bool on = d.state == cia::State::kOperationEnabled;
      const double target_A = on ? target_current_A(d, h) : 0.0;
      // Exact first-order response over the sub-step; the plant gets its
      // mean torque over it.
      const double mean_A = target_A + (d.current_A - target_A) * mean_share;
      d.current_A = target_A + (d.current_A - target_A) * decay;
      d.reported_A.update(d.current_A, h);
      const double sign = d.model.inverted ? -1.0 : 1.0;
      tau[j] = sign * d.model.gear_ratio * d.model.gearbox_efficiency *
               d.model.torque_constant_Nm_per_A() * mean_A;
    }
    if (!all_enabled) {
      plant_->stop();  // the brakes hold the arms while any drive is off
      continue;
    }
    if (!plant_->fault().empty()) continue;
    if (plant_->step(tau, h) != delta::PlantStatus::kOk) {
      for (Drive& d : drives_) enter_fault(d, 0xFF01);
    }
  }
}

// The current, with its noise, once per SYNC: 0x6078 per mille of the
// rated current, 0x6077 in the torque unit.
void Emulator::measure(Drive& d) {
  const double measured_A = d.reported_A.value() + config_.current_noise_A * noise();
  const auto i16 = [](double v) {
    const long r = std::lround(v);
    return static_cast<std::int16_t>(std::max(-32768L, std::min(32767L, r)));
  };
  d.current_measured_pm = i16(measured_A / d.model.rated_current_A * 1000.0);
  const double torque_Nm = measured_A * d.model.torque_constant_Nm_per_A();
  switch (config_.torque_unit) {
    case TorqueUnit::kPerMille:
      d.torque_measured = i16(torque_Nm / d.model.rated_torque_Nm * 1000.0);
      break;
    case TorqueUnit::kMilliamp:
      d.torque_measured = i16(measured_A * 1000.0);
      break;
    case TorqueUnit::kMilliNewtonMetre:
      d.torque_measured = i16(torque_Nm * 1000.0);
      break;
  }
}

// The current set-point of the target torque (0x6071 in the torque unit),
// within the maximum current (0x6073) and torque (0x6072); in profile
// torque the set-point follows at the torque slope (0x6087, 0: at once).
double Emulator::target_current_A(Drive& d, double dt_s) {
  const double kt = d.model.torque_constant_Nm_per_A();
  double target_A = 0.0;
  switch (config_.torque_unit) {
    case TorqueUnit::kPerMille:
      target_A = d.target_torque_pm / 1000.0 * d.model.rated_torque_Nm / kt;
      break;
    case TorqueUnit::kMilliamp:
      target_A = d.target_torque_pm / 1000.0;
      break;
    case TorqueUnit::kMilliNewtonMetre:
      target_A = d.target_torque_pm / 1000.0 / kt;
      break;
  }
  double limit_A = d.max_current_pm / 1000.0 * d.model.rated_current_A;
  if (d.max_torque_pm != 0xFFFF) {
    limit_A = std::min(limit_A, d.max_torque_pm / 1000.0 * d.model.rated_torque_Nm / kt);
  }
  target_A = std::clamp(target_A, -limit_A, limit_A);
  if (d.mode == cia::kModeProfileTorque && d.torque_slope_pm_s != 0) {
    const double step_A = d.torque_slope_pm_s / 1000.0 * d.model.rated_torque_Nm / kt * dt_s;
    target_A = std::clamp(target_A, d.ramped_A - step_A, d.ramped_A + step_A);
  }
  d.ramped_A = target_A;
  return target_A;
}

}  // namespace emu
