#include "fw_linux/trajectories.hpp"

#include <cmath>
#include <iterator>

#include "delta/controller/vocabulary.hpp"
#include "delta/trajectory.hpp"

namespace fw_linux {
namespace {

using delta::fx::Q3_28;
using delta::fx::Q7_24;

using delta::controller::TrajectoryId;

// The catalogue: what each trajectory of the controller's vocabulary is
// (its id and name are the vocabulary's; docs/firmware.md describes them).
struct Preset {
  TrajectoryId id;
  bool fourier;                 // else the default pick-and-place cycle
  unsigned long long seed;      // Fourier: of its coefficients
  unsigned base_frequency_mHz;  // Fourier
  std::uint32_t repetitions;    // Fourier periods or pick-and-place cycles
};

constexpr Preset kCatalogue[] = {
    {TrajectoryId::kPath1, true, 1, 200, 2},
    {TrajectoryId::kPath2, true, 2, 250, 2},
    {TrajectoryId::kPickAndPlace, false, 0, 0, 3},
};
static_assert(std::size(kCatalogue) == delta::controller::kTrajectoryNames.size(),
              "one catalogue entry per trajectory id");
constexpr unsigned kHarmonics = 5;
constexpr double kAmplitudeRad = 0.35;
const delta::Vec3<double> kCentre{0.0, 0.0, -0.42};

fw::TrajectoryConfig fourier(const Preset& preset, const PortConfig& c,
                             const TrajectoryParams& params) {
  delta::FourierTrajectory f;
  const double hz = preset.base_frequency_mHz / 1000.0;
  if (!delta::make_fourier_excitation(c.geometry, kCentre, kHarmonics, hz, kAmplitudeRad,
                                      preset.seed, f)) {
    throw ConfigError(std::string(delta::controller::trajectory_name(preset.id)) +
                      ": no Fourier excitation fits this geometry's workspace");
  }
  fw::TrajectoryConfig t;
  t.kind = fw::TrajectoryKind::kFourier;
  t.tick_period_us = c.period_us;
  t.blend_ticks = static_cast<std::uint32_t>(std::lround(c.blend_s * 1e6 / c.period_us));
  t.fourier.base_frequency_mHz = preset.base_frequency_mHz;
  t.fourier.harmonics = kHarmonics;
  t.fourier.periods = params.repetitions != 0 ? params.repetitions : preset.repetitions;
  const double scale = params.scale_permille / 1000.0;
  const double w = 2.0 * 3.141592653589793 * hz;
  for (unsigned j = 0; j < 3; ++j) {
    t.fourier.q0_rad[j] = to_q<Q3_28>(f.q0_rad[j], "q0");
    for (unsigned k = 0; k < kHarmonics; ++k) {
      // q = a/(k w) sin(k w t) - b/(k w) cos(k w t)  (common/trajectory.hpp)
      const double kw = (k + 1) * w;
      t.fourier.sin_amplitude_rad[j][k] = to_q<Q3_28>(scale * f.a_rad_s[j][k] / kw, "amplitude");
      t.fourier.cos_amplitude_rad[j][k] = to_q<Q3_28>(-scale * f.b_rad_s[j][k] / kw, "amplitude");
    }
  }
  return t;
}

fw::TrajectoryConfig pick_and_place(const Preset& preset, const PortConfig& c,
                                    const TrajectoryParams& params) {
  const delta::PickAndPlaceTrajectory p = delta::default_pick_and_place(c.geometry);
  fw::TrajectoryConfig t;
  t.kind = fw::TrajectoryKind::kPickAndPlace;
  t.tick_period_us = c.period_us;
  const std::size_t n = std::min<std::size_t>(p.points_m.size(), fw::kMaxWaypoints);
  t.pick_and_place.waypoints = static_cast<std::uint8_t>(n);
  // The amplitude scale moves the waypoints towards (or away from) their centre.
  delta::Vec3<double> centre{};
  for (std::size_t i = 0; i < n; ++i) {
    centre.x += p.points_m[i].x / static_cast<double>(n);
    centre.y += p.points_m[i].y / static_cast<double>(n);
    centre.z += p.points_m[i].z / static_cast<double>(n);
  }
  const double scale = params.scale_permille / 1000.0;
  for (std::size_t i = 0; i < n; ++i) {
    t.pick_and_place.points[i] = {
        to_q<Q7_24>(centre.x + scale * (p.points_m[i].x - centre.x), "x"),
        to_q<Q7_24>(centre.y + scale * (p.points_m[i].y - centre.y), "y"),
        to_q<Q7_24>(centre.z + scale * (p.points_m[i].z - centre.z), "z")};
  }
  t.pick_and_place.segment_ticks =
      static_cast<std::uint32_t>(std::lround(p.segment_duration_s * 1e6 / c.period_us));
  t.pick_and_place.cycles = params.repetitions != 0 ? params.repetitions : preset.repetitions;
  return t;
}

}  // namespace

std::vector<std::string> trajectory_names() {
  const auto& names = delta::controller::kTrajectoryNames;
  return {names.begin(), names.end()};
}

std::optional<fw::TrajectoryConfig> named_trajectory(const std::string& name,
                                                     const PortConfig& config,
                                                     const TrajectoryParams& params) {
  TrajectoryId id{};
  if (!delta::controller::trajectory_id(name, id)) return std::nullopt;
  const Preset& preset = kCatalogue[static_cast<std::size_t>(id)];
  return preset.fourier ? fourier(preset, config, params) : pick_and_place(preset, config, params);
}

}  // namespace fw_linux
