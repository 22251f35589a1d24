// The collision detector's settings for the model in use (docs/safety.md):
// the thresholds are the model's own (`host_id fit` derives them from its
// residual and they travel with the model), or the keys' where
// collision.threshold_Nm is given; collision.threshold_scale scales either.
// collision.detect unset turns the detector on wherever the identified
// model is the feed-forward and has thresholds, and off otherwise; true
// insists, and is a problem where it cannot be honoured.
#pragma once

#include <optional>
#include <string>

#include "delta/controller/model_record.hpp"
#include "fw/collision.hpp"
#include "fw_linux/config.hpp"

namespace fw_linux {

struct CollisionSetting {
  fw::CollisionConfig config;
  std::string source;   // "the model's (fit 0x...)", "the keys'", "" none
  std::string problem;  // why collision.detect = true cannot be honoured; "" fine
  std::string off_why;  // why it is off, where it is
};

// `model_in_use`: the identified model is the feed-forward; `thresholds`
// are the ones it carries.
CollisionSetting collision_setting(const PortConfig& c, bool model_in_use,
                                   const std::optional<fw::CollisionThresholds>& thresholds,
                                   std::uint32_t fit_id = 0);

// The thresholds of the configuration's own model (feed_forward.model).
std::optional<fw::CollisionThresholds> model_thresholds(const PortConfig& c);

// "collision detection on: the model's thresholds (fit 0x...), joint 1
// 0.04 N m + ...", or off and why: for delta_fw's start and --check-config.
std::string describe_collision(const CollisionSetting& s);

// A model (or feed-forward mode) set over the bus, applied to `controller`
// (fw::Controller) with the detector's settings that go with it; nullopt
// where the controller refused (a run is on), else those settings.
template <class Controller>
std::optional<CollisionSetting> apply_model(
    Controller& controller, const PortConfig& c, const fw::FeedForwardConfig& f,
    const std::optional<fw::CollisionThresholds>& thresholds) {
  CollisionSetting s = collision_setting(c, f.mode == fw::FeedForwardMode::kModel, thresholds);
  const fw::CollisionConfig before = controller.collision_config();
  if (!controller.set_collision(s.config)) return std::nullopt;
  if (!controller.set_feed_forward(f)) {
    controller.set_collision(before);
    return std::nullopt;
  }
  return s;
}

// Whether a model or mode set over the bus keeps collision.detect = true
// honoured (FeedForwardSlot::set_check): kDetector where it would not.
inline delta::controller::ModelRecordFault collision_check(
    const PortConfig& c, const fw::FeedForwardConfig& f,
    const std::optional<fw::CollisionThresholds>& thresholds) {
  return collision_setting(c, f.mode == fw::FeedForwardMode::kModel, thresholds).problem.empty()
             ? delta::controller::ModelRecordFault::kOk
             : delta::controller::ModelRecordFault::kDetector;
}

}  // namespace fw_linux
