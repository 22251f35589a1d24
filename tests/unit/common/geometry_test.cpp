#include "delta/geometry.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace delta {
namespace {

TEST(GeometryTest, DefaultGeometryIsValid) {
  EXPECT_EQ(check_geometry(kDefaultGeometry), GeometryFault::kOk);
  EXPECT_EQ(describe_geometry_fault(kDefaultGeometry), "");
  EXPECT_NO_THROW(require_valid_geometry(kDefaultGeometry));
}

TEST(GeometryTest, NonPositiveLengthsAreRejectedByName) {
  Geometry g = kDefaultGeometry;
  g.upper_arm_length_m = 0.0;
  EXPECT_EQ(check_geometry(g), GeometryFault::kUpperArmNotPositive);
  EXPECT_NE(describe_geometry_fault(g).find("upper_arm_length_m"), std::string::npos);

  g = kDefaultGeometry;
  g.forearm_length_m = -0.46;
  EXPECT_EQ(check_geometry(g), GeometryFault::kForearmNotPositive);
  EXPECT_NE(
      describe_geometry_fault(g).find("forearm_length_m must be a positive length, got -0.46"),
      std::string::npos);

  g = kDefaultGeometry;
  g.base_radius_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(check_geometry(g), GeometryFault::kBaseRadiusNotPositive);

  g = kDefaultGeometry;
  g.platform_radius_m = -0.01;
  EXPECT_EQ(check_geometry(g), GeometryFault::kPlatformRadiusNegative);
}

TEST(GeometryTest, MechanismThatCannotBeAssembledIsRejected) {
  // Arms of 0.1 + 0.1 cannot bridge a 0.5 m difference of radii.
  const Geometry g{0.1, 0.1, 0.6, 0.1};
  EXPECT_EQ(check_geometry(g), GeometryFault::kCannotAssemble);
  try {
    require_valid_geometry(g);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cannot be assembled"), std::string::npos) << e.what();
  }
}

TEST(GeometryTest, ZeroPlatformRadiusIsAllowed) {
  Geometry g = kDefaultGeometry;
  g.platform_radius_m = 0.0;
  EXPECT_EQ(check_geometry(g), GeometryFault::kOk);
}

}  // namespace
}  // namespace delta
