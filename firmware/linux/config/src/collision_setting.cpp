#include "fw_linux/collision_setting.hpp"

#include <cstdio>

#include "delta/model_q.hpp"
#include "delta/q_conversion.hpp"

namespace fw_linux {

namespace {

// The keys' thresholds, every joint alike.
fw::CollisionThresholds key_thresholds(const PortConfig& c) {
  using delta::fx::Q12_19;
  fw::CollisionThresholds t;
  t.base_Nm.fill(to_q<Q12_19>(*c.collision_threshold_Nm, "collision.threshold_Nm"));
  t.per_speed_Nm_s_per_rad.fill(
      to_q<Q12_19>(c.collision_threshold_per_speed, "collision.threshold_per_speed_Nm_s_per_rad"));
  t.per_acceleration_Nm_s2_per_rad.fill(
      to_q<Q12_19>(c.collision_threshold_per_acceleration,
                   "collision.threshold_per_acceleration_Nm_s2_per_rad"));
  return t;
}

std::string fit_text(std::uint32_t id) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "fit 0x%08X", id);
  return buf;
}

}  // namespace

std::optional<fw::CollisionThresholds> model_thresholds(const PortConfig& c) {
  if (!c.feed_forward_model || !c.feed_forward_model->collision_thresholds) return std::nullopt;
  return delta::collision_thresholds_q(*c.feed_forward_model->collision_thresholds);
}

CollisionSetting collision_setting(const PortConfig& c, bool model_in_use,
                                   const std::optional<fw::CollisionThresholds>& thresholds,
                                   std::uint32_t fit_id) {
  CollisionSetting s;
  s.config.threshold_scale =
      to_q<delta::fx::Q12_19>(c.collision_threshold_scale, "collision.threshold_scale");
  bool have = true;
  if (c.collision_threshold_Nm) {
    s.config.thresholds = key_thresholds(c);
    s.source = "the keys' thresholds (collision.threshold_*)";
  } else if (thresholds) {
    s.config.thresholds = *thresholds;
    s.source = "the model's thresholds" + (fit_id != 0 ? " (" + fit_text(fit_id) + ")" : "");
  } else {
    have = false;
  }
  const bool insist = c.collision_detect.value_or(false);
  if (c.collision_detect.has_value() && !insist) {
    s.off_why = "collision.detect = false";
    return s;
  }
  if (!model_in_use) {
    s.off_why = "the feed-forward is not the identified model";
    if (insist) {
      s.problem =
          "collision.detect = true needs the identified model as the feed-forward "
          "(feed_forward = model, or host_id model load): the detector compares the measured "
          "torque with the model's (docs/safety.md)";
    }
    return s;
  }
  if (!have) {
    s.off_why = "the model in use" + (fit_id != 0 ? " (" + fit_text(fit_id) + ")" : "") +
                " carries no thresholds (fitted before host_id derived them, or a record from "
                "before them kept in feed_forward.store: fit and load it again) and "
                "collision.threshold_Nm is not set";
    if (insist) {
      s.problem = "collision.detect = true needs thresholds: " + s.off_why + " (docs/safety.md)";
    }
    return s;
  }
  s.config.detect = true;
  return s;
}

std::string describe_collision(const CollisionSetting& s) {
  if (!s.problem.empty()) return "collision detection refused: " + s.problem;
  if (!s.config.detect) return "collision detection off: " + s.off_why + " (docs/safety.md)";
  const fw::CollisionThresholds& t = s.config.thresholds;
  std::string text = "collision detection on: " + s.source + ", times " +
                     std::to_string(delta::to_double(s.config.threshold_scale)).substr(0, 5);
  char buf[160];
  for (unsigned j = 0; j < 3; ++j) {
    std::snprintf(buf, sizeof buf,
                  "; joint %u %.4g N m + %.4g N m s/rad |qd| + %.4g N m s^2/rad |qdd|", j + 1,
                  delta::to_double(t.base_Nm[j]), delta::to_double(t.per_speed_Nm_s_per_rad[j]),
                  delta::to_double(t.per_acceleration_Nm_s2_per_rad[j]));
    text += buf;
  }
  return text;
}

}  // namespace fw_linux
