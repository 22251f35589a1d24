// The collision detector's settings for the model in use
// (fw_linux/collision_setting.hpp, docs/safety.md): on by default where the
// identified model is the feed-forward and carries thresholds, off where it
// does not; collision.detect = true insists and says why it cannot; the
// keys' thresholds replace the model's.
#include "fw_linux/collision_setting.hpp"

#include <gtest/gtest.h>

#include "delta/atomic_file.hpp"
#include "delta/dynamics.hpp"
#include "delta/model_q.hpp"
#include "delta/q_conversion.hpp"
#include "fw_linux/port.hpp"
#include "scratch_directory.hpp"

namespace fw_linux {
namespace {

using delta::fx::Q12_19;

fw::CollisionThresholds model_thresholds_of(double base_Nm) {
  fw::CollisionThresholds t;
  t.base_Nm = {Q12_19::from(0.0), Q12_19::from(0.0), Q12_19::from(0.0)};
  t.base_Nm[1] = delta::to_q_saturated<Q12_19>(base_Nm);
  return t;
}

TEST(CollisionSettingTest, OnByDefaultWithAModelThatCarriesThresholds) {
  const PortConfig c;
  const CollisionSetting s = collision_setting(c, true, model_thresholds_of(0.05), 0x1234ABCDu);
  EXPECT_TRUE(s.config.detect);
  EXPECT_TRUE(s.problem.empty());
  EXPECT_EQ(s.config.thresholds, model_thresholds_of(0.05));
  EXPECT_NE(describe_collision(s).find("collision detection on: the model's thresholds (fit "
                                       "0x1234ABCD)"),
            std::string::npos)
      << describe_collision(s);
  // The nominal feed-forward, or a model without thresholds: off, quietly.
  EXPECT_FALSE(collision_setting(c, false, model_thresholds_of(0.05)).config.detect);
  const CollisionSetting none = collision_setting(c, true, std::nullopt);
  EXPECT_FALSE(none.config.detect);
  EXPECT_TRUE(none.problem.empty());
  EXPECT_NE(describe_collision(none).find(
                "collision detection off: the model in use carries no thresholds"),
            std::string::npos)
      << describe_collision(none);
}

TEST(CollisionSettingTest, DetectTrueInsistsAndSaysWhyItCannot) {
  PortConfig c;
  c.collision_detect = true;
  const CollisionSetting nominal = collision_setting(c, false, model_thresholds_of(0.05));
  EXPECT_FALSE(nominal.config.detect);
  EXPECT_NE(nominal.problem.find("needs the identified model as the feed-forward"),
            std::string::npos)
      << nominal.problem;
  const CollisionSetting bare = collision_setting(c, true, std::nullopt);
  EXPECT_FALSE(bare.config.detect);
  EXPECT_NE(bare.problem.find("the model in use carries no thresholds"), std::string::npos)
      << bare.problem;
  c.collision_threshold_Nm = 0.08;
  const CollisionSetting keyed = collision_setting(c, true, std::nullopt);
  EXPECT_TRUE(keyed.config.detect);
  EXPECT_EQ(keyed.config.thresholds.base_Nm[2].raw(), Q12_19::from(0.08).raw());
}

TEST(CollisionSettingTest, TheKeysReplaceTheModelsAndFalseTurnsItOff) {
  PortConfig c;
  c.collision_threshold_Nm = 0.1;
  c.collision_threshold_per_speed = 0.02;
  c.collision_threshold_scale = 1.5;
  const CollisionSetting s = collision_setting(c, true, model_thresholds_of(0.05));
  EXPECT_TRUE(s.config.detect);
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_EQ(s.config.thresholds.base_Nm[j].raw(), Q12_19::from(0.1).raw());
    EXPECT_EQ(s.config.thresholds.per_speed_Nm_s_per_rad[j].raw(), Q12_19::from(0.02).raw());
  }
  EXPECT_EQ(s.config.threshold_scale.raw(), Q12_19::from(1.5).raw());
  EXPECT_NE(describe_collision(s).find("the keys' thresholds"), std::string::npos);
  c.collision_detect = false;
  EXPECT_FALSE(collision_setting(c, true, model_thresholds_of(0.05)).config.detect);
}

// At start (and --check-config, which says the same): the configuration's
// model, or the one kept in feed_forward.store, which takes its place.
TEST(CollisionSettingTest, AtStartTheStoresModelTakesTheConfigurationsPlace) {
  delta::IdentifiedModel m;
  m.kind = "lumped";
  m.geometry = delta::kDefaultGeometry;
  m.parameters = delta::to_high_fidelity(delta::default_lumped_parameters());
  m.fit_id = 0x00C0FFEEu;
  PortConfig c;
  c.feed_forward = fw::FeedForwardMode::kModel;
  c.feed_forward_model = m;
  c.feed_forward_store = "";
  c.collision_detect = true;
  EXPECT_NE(collision_at_start(c).problem.find("(fit 0x00C0FFEE) carries no thresholds"),
            std::string::npos)
      << collision_at_start(c).problem;
  m.collision_thresholds = delta::CollisionThresholds{{0.05, 0.05, 0.05}, {}, {}};
  m.fit_id = 0x0000BEEFu;
  delta::controller::ModelRecordBytes bytes{};
  delta::controller::encode_model_record(delta::model_record(m), bytes);
  c.feed_forward_store = testsupport::process_scratch("collision_setting").file("store.bin");
  delta::write_file_atomically(
      c.feed_forward_store,
      std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  const CollisionSetting s = collision_at_start(c);
  EXPECT_TRUE(s.problem.empty()) << s.problem;
  EXPECT_TRUE(s.config.detect);
  EXPECT_NE(describe_collision(s).find("the model's thresholds (fit 0x0000BEEF)"),
            std::string::npos)
      << describe_collision(s);
}

}  // namespace
}  // namespace fw_linux
