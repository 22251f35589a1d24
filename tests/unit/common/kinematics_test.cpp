#include "delta/kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

namespace delta {
namespace {

using V = Vec3<double>;

// The workspace grid: a box under the default robot, 1 cm spacing, filtered
// to poses that are inside the usable workspace.
std::vector<V> workspace_grid(const Geometry& g) {
  std::vector<V> points;
  const WorkspaceLimits<double> limits;
  for (int ix = -20; ix <= 20; ++ix) {
    for (int iy = -20; iy <= 20; ++iy) {
      for (int iz = 0; iz <= 35; ++iz) {
        const V p{0.01 * ix, 0.01 * iy, -0.25 - 0.01 * iz};
        if (check_workspace(g, p, limits).status == WorkspaceStatus::kInside) points.push_back(p);
      }
    }
  }
  return points;
}

TEST(KinematicsTest, HomePoseWithHorizontalArmsWorkedByHand) {
  // All theta = 0: elbows at radius R + a = 0.3, platform joints at r = 0.035,
  // so z = -sqrt(b^2 - (R + a - r)^2) = -sqrt(0.2116 - 0.070225).
  const Geometry g = kDefaultGeometry;
  const double z = -std::sqrt(0.2116 - 0.265 * 0.265);
  const auto ik = inverse_kinematics(g, V{0.0, 0.0, z});
  ASSERT_EQ(ik.status, KinematicsStatus::kOk);
  for (double t : ik.theta_rad) EXPECT_NEAR(t, 0.0, 1e-14);
  const auto fk = forward_kinematics(g, JointVector<double>{0.0, 0.0, 0.0});
  ASSERT_EQ(fk.status, KinematicsStatus::kOk);
  EXPECT_NEAR(fk.position_m.x, 0.0, 1e-14);
  EXPECT_NEAR(fk.position_m.y, 0.0, 1e-14);
  EXPECT_NEAR(fk.position_m.z, -0.37599867021037, 1e-12);
  // Turning all arms down together at 1 rad/s moves every elbow, hence the
  // platform, straight down at a = 0.2 m/s.
  const auto vk = velocity_kinematics(g, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, fk.position_m);
  ASSERT_EQ(vk.status, KinematicsStatus::kOk);
  const V pdot = vk.jacobian * V{1.0, 1.0, 1.0};
  EXPECT_NEAR(pdot.x, 0.0, 1e-14);
  EXPECT_NEAR(pdot.y, 0.0, 1e-14);
  EXPECT_NEAR(pdot.z, -0.2, 1e-14);
}

TEST(KinematicsTest, SymmetricPoseAtThirtyDegreesWorkedByHand) {
  // theta = 30 deg: elbow radius R + a cos = 0.1 + 0.2 * 0.8660254 = 0.27320508,
  // elbow height -a sin = -0.1; z = -0.1 - sqrt(b^2 - (0.27320508 - r)^2).
  const Geometry g = kDefaultGeometry;
  const double radial = 0.1 + 0.2 * std::sqrt(3.0) / 2.0 - 0.035;
  const double z = -0.1 - std::sqrt(0.46 * 0.46 - radial * radial);
  EXPECT_NEAR(z, -0.49352044356, 1e-10);
  const auto ik = inverse_kinematics(g, V{0.0, 0.0, z});
  ASSERT_EQ(ik.status, KinematicsStatus::kOk);
  for (double t : ik.theta_rad) EXPECT_NEAR(t, std::numbers::pi / 6.0, 1e-13);
}

TEST(KinematicsTest, ForwardOfInverseIsIdentityOverWorkspaceGrid) {
  const Geometry g = kDefaultGeometry;
  const auto grid = workspace_grid(g);
  ASSERT_GT(grid.size(), 20000u);  // the grid is dense: 41 x 41 x 36 candidates
  double worst = 0.0;
  for (const V& p : grid) {
    const auto ik = inverse_kinematics(g, p);
    ASSERT_EQ(ik.status, KinematicsStatus::kOk);
    const auto fk = forward_kinematics(g, ik.theta_rad);
    ASSERT_EQ(fk.status, KinematicsStatus::kOk);
    worst = std::max(worst, std::sqrt((fk.position_m - p).squared_norm()));
    // And the inverse of the forward: q -> p -> q.
    const auto ik2 = inverse_kinematics(g, fk.position_m);
    ASSERT_EQ(ik2.status, KinematicsStatus::kOk);
    for (unsigned i = 0; i < 3; ++i) {
      worst = std::max(worst, std::abs(ik2.theta_rad[i] - ik.theta_rad[i]));
    }
  }
  EXPECT_LT(worst, 1e-12);
}

TEST(KinematicsTest, InverseOfForwardIsIdentityOverJointGrid) {
  const Geometry g = kDefaultGeometry;
  int checked = 0;
  double worst = 0.0;
  for (double q1 = -0.6; q1 <= 1.2; q1 += 0.1) {
    for (double q2 = -0.6; q2 <= 1.2; q2 += 0.1) {
      for (double q3 = -0.6; q3 <= 1.2; q3 += 0.1) {
        const JointVector<double> q{q1, q2, q3};
        const auto fk = forward_kinematics(g, q);
        if (fk.status != KinematicsStatus::kOk) continue;
        if (check_workspace(g, fk.position_m, WorkspaceLimits<double>{}).status !=
            WorkspaceStatus::kInside) {
          continue;
        }
        const auto ik = inverse_kinematics(g, fk.position_m);
        ASSERT_EQ(ik.status, KinematicsStatus::kOk);
        for (unsigned i = 0; i < 3; ++i) worst = std::max(worst, std::abs(ik.theta_rad[i] - q[i]));
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 3000);
  EXPECT_LT(worst, 1e-12);
}

TEST(KinematicsTest, JacobianMatchesFiniteDifferencesOfForwardKinematics) {
  const Geometry g = kDefaultGeometry;
  const JointVector<double> poses[] = {{0.3, 0.1, 0.5}, {-0.2, 0.6, 0.2}, {0.9, 0.4, -0.1}};
  for (const auto& q : poses) {
    const auto fk = forward_kinematics(g, q);
    ASSERT_EQ(fk.status, KinematicsStatus::kOk);
    const auto vk = velocity_kinematics(g, q, {0.0, 0.0, 0.0}, fk.position_m);
    ASSERT_EQ(vk.status, KinematicsStatus::kOk);
    const double h = 1e-6;
    for (unsigned j = 0; j < 3; ++j) {
      JointVector<double> qp = q, qm = q;
      qp[j] += h;
      qm[j] -= h;
      const V col = (forward_kinematics(g, qp).position_m - forward_kinematics(g, qm).position_m) *
                    (1.0 / (2.0 * h));
      for (unsigned r = 0; r < 3; ++r) EXPECT_NEAR(vk.jacobian(r, j), col[r], 1e-8);
    }
  }
}

TEST(KinematicsTest, JacobianDotTimesQdotMatchesSecondDifferenceAlongAPath) {
  // Along q(t) = q0 + v t + w t^2 / 2: pddot = J qdd + Jdot qdot, checked
  // against the central second difference of FK(q(t)).
  const Geometry g = kDefaultGeometry;
  const JointVector<double> q0{0.35, 0.05, 0.55};
  const JointVector<double> v{1.3, -0.8, 0.6};
  const JointVector<double> w{-2.0, 4.0, 1.5};
  const auto q_at = [&](double t) {
    return JointVector<double>{q0[0] + v[0] * t + 0.5 * w[0] * t * t,
                               q0[1] + v[1] * t + 0.5 * w[1] * t * t,
                               q0[2] + v[2] * t + 0.5 * w[2] * t * t};
  };
  const double h = 1e-4;
  const V p0 = forward_kinematics(g, q_at(0.0)).position_m;
  const V pddot_fd = (forward_kinematics(g, q_at(h)).position_m - p0 * 2.0 +
                      forward_kinematics(g, q_at(-h)).position_m) *
                     (1.0 / (h * h));
  const auto vk = velocity_kinematics(g, q0, v, p0);
  ASSERT_EQ(vk.status, KinematicsStatus::kOk);
  const V pddot = vk.jacobian * V{w[0], w[1], w[2]} + vk.jacobian_dot_qdot;
  for (unsigned r = 0; r < 3; ++r) EXPECT_NEAR(pddot[r], pddot_fd[r], 1e-6);
  // The velocity term alone is not negligible here, so the check has teeth.
  EXPECT_GT(std::sqrt(vk.jacobian_dot_qdot.squared_norm()), 0.05);
}

TEST(KinematicsTest, UnreachableTargetsAreReportedNotNaN) {
  const Geometry g = kDefaultGeometry;
  // Too far below: a + b = 0.66 is the longest reach.
  auto ik = inverse_kinematics(g, V{0.0, 0.0, -0.9});
  EXPECT_EQ(ik.status, KinematicsStatus::kUnreachable);
  EXPECT_GE(ik.failed_chain, 0);
  for (double t : ik.theta_rad) EXPECT_EQ(t, 0.0);
  // Far off to the side: chain 1 (azimuth 0) is the first to fail.
  ik = inverse_kinematics(g, V{-0.8, 0.0, -0.3});
  EXPECT_EQ(ik.status, KinematicsStatus::kUnreachable);
  EXPECT_EQ(ik.failed_chain, 0);
  // NaN input is unreachable, not NaN output.
  ik = inverse_kinematics(g, V{std::nan(""), 0.0, -0.4});
  EXPECT_EQ(ik.status, KinematicsStatus::kUnreachable);
  // Forearms of 0.1 m cannot meet over sphere centres 0.265 m from the axis.
  const Geometry short_forearms{0.2, 0.1, 0.1, 0.035};
  const auto fk = forward_kinematics(short_forearms, JointVector<double>{0.0, 0.0, 0.0});
  EXPECT_EQ(fk.status, KinematicsStatus::kUnreachable);
}

TEST(KinematicsTest, WorkspaceCheckNamesTheReason) {
  const Geometry g = kDefaultGeometry;
  const WorkspaceLimits<double> limits;
  EXPECT_EQ(check_workspace(g, V{0.0, 0.0, -0.45}, limits).status, WorkspaceStatus::kInside);
  EXPECT_EQ(check_workspace(g, V{0.0, 0.0, -1.0}, limits).status, WorkspaceStatus::kUnreachable);
  // Reachable, but arm 1 would have to point 84 degrees up.
  const auto w = check_workspace(g, V{0.12, 0.0, -0.26}, limits);
  EXPECT_EQ(w.status, WorkspaceStatus::kJointLimit);
  EXPECT_EQ(w.chain, 0);
  EXPECT_NEAR(w.theta_rad[0], -1.4614, 1e-4);
  // Fully stretched below (max reach sqrt((a+b)^2 - (R-r)^2) = 0.65679): the
  // forearms line up with the arms. With the
  // joint limits out of the way, the singularity is what is reported.
  WorkspaceLimits<double> wide = limits;
  wide.joint_min_rad = -3.0;
  wide.joint_max_rad = 3.0;
  EXPECT_EQ(check_workspace(g, V{0.0, 0.0, -0.6565}, wide).status, WorkspaceStatus::kNearSingular);
  EXPECT_EQ(check_workspace(g, V{0.0, 0.0, -0.6565}, limits).status, WorkspaceStatus::kJointLimit);
}

}  // namespace
}  // namespace delta
