#include "fw_linux/trajectories.hpp"

#include <cmath>
#include <iterator>
#include <numbers>

#include "delta/controller/vocabulary.hpp"
#include "delta/custom_trajectory_block.hpp"
#include "delta/trajectory.hpp"

namespace fw_linux {
namespace {

using delta::fx::Q3_28;
using delta::fx::Q7_24;

using delta::controller::TrajectoryId;

// The catalogue: what each trajectory of the controller's vocabulary is
// (its id and name are the vocabulary's; the Fourier ones' generator
// arguments are common's fourier_preset(); docs/firmware.md describes them).
enum class Source { kFourierPreset, kPickAndPlace, kCustom };
struct Preset {
  TrajectoryId id;
  Source source;
  std::uint32_t repetitions;  // pick-and-place cycles (Fourier: the preset's periods)
};

constexpr Preset kCatalogue[] = {
    {TrajectoryId::kPath1, Source::kFourierPreset, 0},
    {TrajectoryId::kPath2, Source::kFourierPreset, 0},
    {TrajectoryId::kPickAndPlace, Source::kPickAndPlace, 3},
    {TrajectoryId::kCustom, Source::kCustom, 0},
};
static_assert(std::size(kCatalogue) == delta::controller::kTrajectoryNames.size(),
              "one catalogue entry per trajectory id");

fw::TrajectoryConfig fourier(const Preset& preset, const PortConfig& c,
                             const TrajectoryParams& params) {
  const std::string name(delta::controller::trajectory_name(preset.id));
  const delta::FourierPreset* fp = delta::fourier_preset(name.c_str());
  if (fp == nullptr) throw ConfigError(name + ": not a Fourier preset");
  delta::BlendedFourierTrajectory t;
  if (!delta::make_fourier_excitation(c.geometry, fp->centre_m, fp->harmonics,
                                      fp->base_frequency_hz, fp->amplitude_rad, fp->seed,
                                      t.fourier)) {
    throw ConfigError(name + ": no Fourier excitation fits this geometry's workspace");
  }
  t.blend_s = c.blend_s;
  t.periods = params.repetitions != 0 ? params.repetitions : fp->periods;
  return fourier_config(t, c.period_us, params.scale_permille);
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

fw::TrajectoryConfig fourier_config(const delta::BlendedFourierTrajectory& t,
                                    std::uint32_t period_us, std::uint16_t scale_permille) {
  const auto& f = t.fourier;
  const std::size_t harmonics = f.a_rad_s[0].size();
  if (harmonics < 1 || harmonics > static_cast<std::size_t>(fw::kMaxHarmonics)) {
    throw ConfigError("a Fourier trajectory needs 1 to " + std::to_string(fw::kMaxHarmonics) +
                      " harmonics, got " + std::to_string(harmonics));
  }
  const double mHz = f.base_frequency_hz * 1000.0;
  if (!(std::abs(mHz - std::round(mHz)) < 1e-9 * mHz) || !(mHz >= 1.0)) {
    throw ConfigError("a Fourier trajectory's base frequency must be a whole number of mHz");
  }
  fw::TrajectoryConfig c;
  c.kind = fw::TrajectoryKind::kFourier;
  c.tick_period_us = period_us;
  c.blend_ticks = static_cast<std::uint32_t>(std::lround(t.blend_s * 1e6 / period_us));
  c.fourier.base_frequency_mHz = static_cast<std::uint32_t>(std::lround(mHz));
  c.fourier.harmonics = static_cast<std::uint8_t>(harmonics);
  c.fourier.periods = t.periods;
  const double scale = scale_permille / 1000.0;
  const double w = 2.0 * std::numbers::pi * f.base_frequency_hz;
  for (unsigned j = 0; j < 3; ++j) {
    c.fourier.q0_rad[j] = to_q<Q3_28>(f.q0_rad[j], "q0");
    for (std::size_t k = 0; k < harmonics; ++k) {
      // q = a/(k w) sin(k w t) - b/(k w) cos(k w t)  (common/trajectory.hpp)
      const double kw = static_cast<double>(k + 1) * w;
      c.fourier.sin_amplitude_rad[j][k] = to_q<Q3_28>(scale * f.a_rad_s[j][k] / kw, "amplitude");
      c.fourier.cos_amplitude_rad[j][k] = to_q<Q3_28>(-scale * f.b_rad_s[j][k] / kw, "amplitude");
    }
  }
  return c;
}

fw::TrajectoryConfig custom_trajectory(const std::uint16_t* block, const PortConfig& config,
                                       const TrajectoryParams& params) {
  delta::BlendedFourierTrajectory t = delta::custom_trajectory_of(block);
  if (t.fourier.a_rad_s[0].empty()) {
    throw ConfigError("custom: no custom trajectory (custom_harmonics is 0)");
  }
  if (params.repetitions != 0) t.periods = params.repetitions;
  return fourier_config(t, config.period_us, params.scale_permille);
}

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
  switch (preset.source) {
    case Source::kFourierPreset:
      return fourier(preset, config, params);
    case Source::kPickAndPlace:
      return pick_and_place(preset, config, params);
    case Source::kCustom:
      break;
  }
  if (config.custom_block.empty()) {
    throw ConfigError(
        "custom: no custom trajectory (set trajectory_file, or upload one over Modbus)");
  }
  return custom_trajectory(config.custom_block.data(), config, params);
}

}  // namespace fw_linux
