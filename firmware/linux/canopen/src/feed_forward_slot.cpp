#include "fw_linux/feed_forward_slot.hpp"

#include <cstdio>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <vector>

#include "delta/atomic_file.hpp"
#include "delta/model_q.hpp"

namespace fw_linux {

namespace mc = delta::controller;

namespace {

std::string fit_text(std::uint32_t id) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08X", id);
  return buf;
}

const char* kind_text(delta::fx::ModelKind k) {
  return k == delta::fx::ModelKind::kLumped ? "lumped" : "delta";
}

}  // namespace

FeedForwardSlot::FeedForwardSlot(const PortConfig& c, const fw::ControllerConfig& core)
    : geometry_(core.geometry), store_path_(c.feed_forward_store), current_(core.feed_forward) {
  if (c.feed_forward_model) {
    const mc::ModelRecord r = delta::model_record(*c.feed_forward_model);
    mc::ModelRecordBytes bytes{};
    mc::encode_model_record(r, bytes);
    keep(bytes, r);
  }
  if (store_path_.empty()) return;
  std::ifstream in(store_path_, std::ios::binary);
  if (!in) return;  // nothing loaded over the bus yet
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  mc::ModelRecord r;
  Fault f = mc::decode_model_record(bytes, r);
  if (f == Fault::kOk && !mc::same_geometry_q(r.geometry, geometry_)) f = Fault::kGeometry;
  if (f != Fault::kOk) {
    startup_note_ = "warning: the stored model " + store_path_ +
                    " is not used: " + mc::model_record_fault_name(f) +
                    "; the configuration's feed-forward is";
    return;
  }
  keep(bytes, r);
  current_.mode = fw::FeedForwardMode::kModel;
  current_.model = delta::fx::prepare_model(geometry_, r.parameters);
  startup_note_ =
      std::string("the ") + kind_text(r.parameters.kind) + " model, fit " + fit_text(r.fit_id) +
      ", loaded over the bus and kept in " + store_path_ +
      (c.feed_forward_model ? " (it replaces feed_forward.model " + c.feed_forward_model_file +
                                  "; remove " + store_path_ + " to use that)"
                            : "");
}

std::span<const std::uint8_t> FeedForwardSlot::record() const {
  return std::span<const std::uint8_t>(record_.data(), record_bytes_);
}

// A checked record as the model in use: its bytes (a delta-model/1 one as
// it came), fit id and thresholds.
void FeedForwardSlot::keep(std::span<const std::uint8_t> bytes, const mc::ModelRecord& r) {
  std::copy(bytes.begin(), bytes.end(), record_.begin());
  record_bytes_ = bytes.size();
  fit_id_ = r.fit_id;
  thresholds_.reset();
  if (r.has_collision_thresholds) thresholds_ = r.collision_thresholds;
}

FeedForwardSlot::Fault FeedForwardSlot::apply(
    const fw::FeedForwardConfig& next, const std::optional<fw::CollisionThresholds>& thresholds,
    bool between_runs) {
  if (!between_runs || (apply_ && !apply_(next, thresholds))) return Fault::kBusy;
  current_ = next;
  return Fault::kOk;
}

FeedForwardSlot::Fault FeedForwardSlot::load(std::span<const std::uint8_t> bytes,
                                             bool between_runs) {
  mc::ModelRecord r;
  Fault f = mc::decode_model_record(bytes, r);
  if (f == Fault::kOk && !mc::same_geometry_q(r.geometry, geometry_)) f = Fault::kGeometry;
  if (f == Fault::kOk && !between_runs) f = Fault::kBusy;
  fw::FeedForwardConfig next = current_;
  std::optional<fw::CollisionThresholds> thresholds;
  if (f == Fault::kOk) {
    next.mode = fw::FeedForwardMode::kModel;
    next.model = delta::fx::prepare_model(geometry_, r.parameters);
    if (r.has_collision_thresholds) thresholds = r.collision_thresholds;
    if (check_) f = check_(next, thresholds);
  }
  if (f == Fault::kOk && !store_path_.empty()) {
    try {
      delta::write_file_atomically(
          store_path_, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    } catch (const std::exception&) {
      f = Fault::kNotStored;
    }
  }
  if (f == Fault::kOk) f = apply(next, thresholds, between_runs);
  if (f == Fault::kOk) keep(bytes, r);
  last_load_ = f;
  report_load(f, r.fit_id);
  return f;
}

// Every load over the bus, taken or refused, in delta_fw's log (who may
// load a model: docs/security.md).
void FeedForwardSlot::report_load(Fault f, std::uint32_t fit_id) const {
  if (!report_) return;
  char id[16];
  std::snprintf(id, sizeof id, "0x%08X", fit_id);
  if (f == Fault::kOk) {
    report_(std::string("model fit ") + id +
            " loaded over the bus (SDO download to node 16, 0x2200:1)" +
            (store_path_.empty() ? "" : ", stored in " + store_path_) +
            "; the feed-forward from the next run on");
  } else {
    report_(std::string("a model load over the bus (SDO download to node 16, 0x2200:1) was "
                        "refused: ") +
            mc::model_record_fault_name(f) + " (0x2200:4 = " + std::to_string(static_cast<int>(f)) +
            "); the model in use stays");
  }
}

FeedForwardSlot::Fault FeedForwardSlot::set_mode(std::uint32_t mode, bool between_runs) {
  const bool known = mode <= static_cast<std::uint32_t>(fw::FeedForwardMode::kModel);
  fw::FeedForwardConfig next = current_;
  next.mode = known ? static_cast<fw::FeedForwardMode>(mode) : current_.mode;
  Fault f = known ? Fault::kOk : Fault::kValue;
  if (f == Fault::kOk && next.mode == fw::FeedForwardMode::kModel && record_bytes_ == 0) {
    f = Fault::kKind;  // no model to run
  }
  if (f == Fault::kOk && check_) f = check_(next, thresholds_);
  if (f == Fault::kOk) f = apply(next, thresholds_, between_runs);
  if (report_) {
    const std::string asked =
        known ? fw::feed_forward_mode_name(next.mode) : std::to_string(mode) + " (no such mode)";
    report_("feed-forward " + asked + " asked over the bus (0x2200:3): " +
            (f == Fault::kOk ? "from the next run on"
                             : std::string("refused, ") + mc::model_record_fault_name(f)));
  }
  return f;
}

void FeedForwardSlot::note_refused_download(const std::string& why) const {
  if (report_) {
    report_("a model load over the bus (SDO download to node 16, 0x2200:1) was refused: " + why +
            "; the model in use stays");
  }
}

}  // namespace fw_linux
