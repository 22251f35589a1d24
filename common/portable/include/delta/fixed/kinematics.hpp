// Delta kinematics in fixed point, following docs/conventions.md
// like the double version in delta/kinematics.hpp (same equations, same
// branch choices), for the firmware core. Lengths are Q7.24 metres, angles
// Q3.28 radians. Agreement with the double version over the workspace grid
// (tests/unit/common/fixed_kinematics_test.cpp): better than 2e-5 rad and
// 10 um; see docs/design/fixed-point-core.md for the measured figures.
#pragma once

#include <array>

#include "delta/fixed/math.hpp"
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

// Chain azimuths 0, 120, 240 degrees: cos and sin in Q1.30.
inline constexpr Q1_30 kChainCosQ[3] = {Q1_30::from(1.0), Q1_30::from(-0.5), Q1_30::from(-0.5)};
inline constexpr Q1_30 kChainSinQ[3] = {Q1_30::from(0.0), Q1_30::from(0.86602540378443864676),
                                        Q1_30::from(-0.86602540378443864676)};

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
// The same from the angles' sines and cosines (sincos(q[k])), for a caller
// that has them already.
ForwardKinematicsQ forward_kinematics(const GeometryQ& g, const std::array<SinCos, 3>& trig);

// Elbow position of one chain, at an angle or from its sine and cosine.
Vec3Q elbow_position(const GeometryQ& g, int chain, Q3_28 theta_rad);
Vec3Q elbow_position(const GeometryQ& g, int chain, const SinCos& trig);

}  // namespace delta::fx
