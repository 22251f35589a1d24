// The outcome of a kinematics computation, shared by the double and the
// fixed-point kinematics. Stable numeric codes.
#pragma once

namespace delta {

enum class KinematicsStatus : int {
  kOk = 0,
  kUnreachable = 1,  // no joint angle / platform position satisfies the chain
  kSingular = 2,     // the pose is (numerically) singular
};

}  // namespace delta
