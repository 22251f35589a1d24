// Delta kinematics in fixed point, following docs/conventions.md
// like the double version in delta/kinematics.hpp (same equations, same
// branch choices), for the firmware core. Lengths are Q7.24 metres, angles
// Q3.28 radians. Agreement with the double version over the workspace grid
// (tests/unit/common/fixed_kinematics_test.cpp): better than 2e-5 rad and
// 10 um; see docs/firmware.md for the measured figures.
#pragma once

#include <array>

#include "delta/fixed/q.hpp"
#include "delta/kinematics_status.hpp"

namespace delta::fx {

struct GeometryQ {
  Q7_24 upper_arm_length_m;
  Q7_24 forearm_length_m;
  Q7_24 base_radius_m;
  Q7_24 platform_radius_m;
  friend constexpr bool operator==(const GeometryQ&, const GeometryQ&) = default;
};

struct Vec3Q {
  Q7_24 x_m, y_m, z_m;
};

using JointAnglesQ = std::array<Q3_28, 3>;

struct InverseKinematicsQ {
  KinematicsStatus status{KinematicsStatus::kUnreachable};
  int failed_chain{-1};
  JointAnglesQ theta_rad{};
};

struct ForwardKinematicsQ {
  KinematicsStatus status{KinematicsStatus::kUnreachable};
  Vec3Q position{};
};

// Joint angles for platform position p on the working branch (elbow farther
// from the z axis). Unreachable targets are reported with the chain.
InverseKinematicsQ inverse_kinematics(const GeometryQ& g, const Vec3Q& p);

// Platform position for joint angles q (the solution below the elbows).
ForwardKinematicsQ forward_kinematics(const GeometryQ& g, const JointAnglesQ& q);

// Elbow position of one chain.
Vec3Q elbow_position(const GeometryQ& g, int chain, Q3_28 theta_rad);

}  // namespace delta::fx
