// Excitation design against the controller: the host's double-precision
// copy of the controller's Fourier trajectory (blends included) against
// the core's fixed-point one, and a designed excitation checked by the
// firmware's own trajectory check.
#include "host_id/design.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "delta/q_conversion.hpp"
#include "fw/trajectory.hpp"
#include "fw_linux/config.hpp"
#include "fw_linux/trajectories.hpp"

namespace {

using delta::to_double;

TEST(DesignTest, TheHostsFourierTrajectoryIsTheControllers) {
  const fw_linux::PortConfig config;
  const auto fw_config = fw_linux::named_trajectory("path1", config);
  ASSERT_TRUE(fw_config.has_value());
  const fw::ControllerConfig core = fw_linux::controller_config(config);
  const fw::Trajectory fw_path(core.geometry, *fw_config);
  const delta::BlendedFourierTrajectory host_path =
      host_id::preset_trajectory("path1", delta::default_robot_description(), config.blend_s);
  const double dt = config.period_us * 1e-6;
  EXPECT_EQ(fw_path.length_ticks(),
            static_cast<std::uint32_t>(std::lround(host_path.duration_s() / dt)));
  double worst_q = 0, worst_qd = 0, worst_qdd = 0;
  for (std::uint32_t tick = 0; tick <= fw_path.length_ticks(); tick += 7) {
    fw::JointReference ref;
    ASSERT_EQ(fw_path.reference(tick, ref), delta::KinematicsStatus::kOk);
    const delta::JointState s = host_path.at(tick * dt);
    for (unsigned j = 0; j < 3; ++j) {
      worst_q = std::max(worst_q, std::abs(to_double(ref.q_rad[j]) - s.q_rad[j]));
      worst_qd = std::max(worst_qd, std::abs(to_double(ref.qd_rad_s[j]) - s.qd_rad_s[j]));
      worst_qdd = std::max(worst_qdd, std::abs(to_double(ref.qdd_rad_s2[j]) - s.qdd_rad_s2[j]));
    }
  }
  std::cout << "largest difference: q " << worst_q << " rad, qd " << worst_qd << " rad/s, qdd "
            << worst_qdd << " rad/s^2\n";
  EXPECT_LT(worst_q, 1e-6);
  EXPECT_LT(worst_qd, 1e-4);
  EXPECT_LT(worst_qdd, 1e-2);
}

// The bar: on the default robot, a scaled condition number at most
// half that of path1, with every limit respected on every tick by the
// firmware's own check (and every 1 ms by the design's, torque included).
TEST(DesignTest, ADesignedExcitationIsBetterConditionedThanPath1AndTheControllerAcceptsIt) {
  const delta::RobotDescription robot = delta::default_robot_description();
  host_id::DesignOptions o = host_id::default_design_options();
  const host_id::DesignResult d = host_id::design_excitation(o, robot);
  const host_id::ExcitationQuality path1 =
      host_id::excitation_quality(host_id::preset_trajectory("path1", robot, o.blend_s), o, robot);
  std::cout << "designed: condition number " << d.quality.condition_number_scaled << " in "
            << d.seconds << " s (" << d.pso.evaluations << " evaluations), largest torque "
            << d.quality.largest_torque_Nm << " N m; path1: " << path1.condition_number_scaled
            << "\n";
  ASSERT_TRUE(d.quality.feasible) << d.quality.violation;
  EXPECT_LE(d.quality.condition_number_scaled, 0.5 * path1.condition_number_scaled);
  const fw_linux::PortConfig config;
  const fw::ControllerConfig core = fw_linux::controller_config(config);
  const fw::TrajectoryCheck check = fw::check_trajectory(
      core.geometry, fw_linux::fourier_config(d.trajectory, config.period_us), core.limits);
  EXPECT_EQ(check.fault, fw::TrajectoryFault::kOk)
      << "tick " << check.tick << " joint " << check.joint;
}

}  // namespace
