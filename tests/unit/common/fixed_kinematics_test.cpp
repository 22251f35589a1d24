// The fixed-point kinematics against the double version over the workspace
// grid: better than 2e-5 rad and 10 um.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "delta/fixed/kinematics.hpp"
#include "delta/kinematics.hpp"

namespace delta::fx {
namespace {

constexpr double kQ24 = 16777216.0;
constexpr double kQ28 = 268435456.0;

Q7_24 length_q(double v) {
  return Q7_24::from_raw(static_cast<std::int32_t>(std::llround(v * kQ24)));
}
Q3_28 angle_q(double v) {
  return Q3_28::from_raw(static_cast<std::int32_t>(std::llround(v * kQ28)));
}

GeometryQ to_q(const Geometry& g) {
  return {length_q(g.upper_arm_length_m), length_q(g.forearm_length_m), length_q(g.base_radius_m),
          length_q(g.platform_radius_m)};
}

TEST(FixedKinematicsTest, AgreesWithDoubleOverTheWorkspaceGrid) {
  const Geometry g = kDefaultGeometry;
  const GeometryQ gq = to_q(g);
  const WorkspaceLimits<double> limits;
  double worst_ik = 0.0, worst_fk = 0.0;
  int points = 0;
  for (int ix = -20; ix <= 20; ++ix) {
    for (int iy = -20; iy <= 20; ++iy) {
      for (int iz = 0; iz <= 35; ++iz) {
        const Vec3<double> p{0.01 * ix, 0.01 * iy, -0.25 - 0.01 * iz};
        const auto w = check_workspace(g, p, limits);
        if (w.status != WorkspaceStatus::kInside) continue;
        ++points;
        const auto ik = inverse_kinematics(gq, Vec3Q{length_q(p.x), length_q(p.y), length_q(p.z)});
        ASSERT_EQ(ik.status, KinematicsStatus::kOk);
        JointAnglesQ q{};
        for (unsigned k = 0; k < 3; ++k) {
          worst_ik = std::max(worst_ik, std::abs(ik.theta_rad[k].raw() / kQ28 - w.theta_rad[k]));
          q[k] = angle_q(w.theta_rad[k]);
        }
        const auto fk = forward_kinematics(gq, q);
        ASSERT_EQ(fk.status, KinematicsStatus::kOk);
        const double ex = fk.position.x_m.raw() / kQ24 - p.x;
        const double ey = fk.position.y_m.raw() / kQ24 - p.y;
        const double ez = fk.position.z_m.raw() / kQ24 - p.z;
        worst_fk = std::max(worst_fk, std::sqrt(ex * ex + ey * ey + ez * ez));
      }
    }
  }
  std::printf("fixed kinematics over %d grid points: IK worst %.3g rad, FK worst %.3g m\n", points,
              worst_ik, worst_fk);
  EXPECT_GT(points, 20000);
  EXPECT_LT(worst_ik, 2e-5);
  EXPECT_LT(worst_fk, 10e-6);
}

TEST(FixedKinematicsTest, HomePoseWorkedByHand) {
  const GeometryQ gq = to_q(kDefaultGeometry);
  const auto fk = forward_kinematics(gq, JointAnglesQ{});
  ASSERT_EQ(fk.status, KinematicsStatus::kOk);
  EXPECT_NEAR(fk.position.z_m.raw() / kQ24, -0.37599867021037, 1e-6);
  EXPECT_NEAR(fk.position.x_m.raw() / kQ24, 0.0, 1e-6);
}

TEST(FixedKinematicsTest, UnreachableTargetsAreReportedNotAnsweredWithGarbage) {
  const GeometryQ gq = to_q(kDefaultGeometry);
  auto ik = inverse_kinematics(gq, Vec3Q{length_q(0.0), length_q(0.0), length_q(-0.9)});
  EXPECT_EQ(ik.status, KinematicsStatus::kUnreachable);
  for (const Q3_28 t : ik.theta_rad) EXPECT_EQ(t.raw(), 0);
  ik = inverse_kinematics(gq, Vec3Q{length_q(-0.8), length_q(0.0), length_q(-0.3)});
  EXPECT_EQ(ik.status, KinematicsStatus::kUnreachable);
  EXPECT_EQ(ik.failed_chain, 0);
  const GeometryQ short_forearms = to_q(Geometry{0.2, 0.1, 0.1, 0.035});
  EXPECT_EQ(forward_kinematics(short_forearms, JointAnglesQ{}).status,
            KinematicsStatus::kUnreachable);
}

}  // namespace
}  // namespace delta::fx
