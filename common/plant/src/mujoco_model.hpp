// What the MJCF writer and the plant share: the robot's home pose.
#pragma once

#include "delta/robot_description.hpp"
#include "delta/vec3.hpp"

namespace delta {

// The platform centre with every arm horizontal (the model's qpos0).
Vec3<double> home_platform_position(const RobotDescription& d);

// A forearm rod's direction, elbow to platform, in its arm's frame (x
// radial out, y the motor axis, z up) at home: the same for every chain.
Vec3<double> rod_home_direction(const RobotDescription& d);

}  // namespace delta
