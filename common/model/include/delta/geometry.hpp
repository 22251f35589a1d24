// The delta's geometry: the four lengths of docs/conventions.md,
// named as in the contract, and its validation.
#pragma once

#include <array>
#include <string>

namespace delta {

template <class T>
struct BasicGeometry {
  T upper_arm_length_m{};  // motor axis to elbow
  T forearm_length_m{};    // elbow to platform joint
  T base_radius_m{};       // base centre to motor axis
  T platform_radius_m{};   // platform centre to platform joint
};

using Geometry = BasicGeometry<double>;

// Why a geometry was rejected; kOk when it is valid.
enum class GeometryFault : int {
  kOk = 0,
  kUpperArmNotPositive = 1,
  kForearmNotPositive = 2,
  kBaseRadiusNotPositive = 3,
  kPlatformRadiusNegative = 4,
  kCannotAssemble = 5,
};

// Checks finiteness and signs of the lengths, and that the chains can be
// assembled: some pose exists where every forearm reaches its elbow, which
// needs upper_arm + forearm > |base_radius - platform_radius|.
GeometryFault check_geometry(const Geometry& g);

// A sentence that says what is wrong with g, with the offending values;
// empty for a valid geometry.
std::string describe_geometry_fault(const Geometry& g);

// Throws std::invalid_argument with describe_geometry_fault() when g is
// invalid. For configuration time on the host.
void require_valid_geometry(const Geometry& g);

// The default robot: the dimensions of the paper's delta, also used by
// `host_id simulate` and the emulator when no geometry is given.
inline constexpr Geometry kDefaultGeometry{0.20, 0.46, 0.10, 0.035};

// Chain azimuths phi_i = 0, 120, 240 degrees: cosines and sines.
inline constexpr std::array<double, 3> kChainCos{1.0, -0.5, -0.5};
inline constexpr std::array<double, 3> kChainSin{0.0, 0.86602540378443864676,
                                                 -0.86602540378443864676};

}  // namespace delta
