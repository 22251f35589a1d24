// The controller's feed-forward as node 16 serves it (docs/protocol.md,
// 0x2200): the mode and the identified model in use, a model loaded over
// the bus (a delta-model/3 record, checked whole: format, CRC, kind, every
// value, the geometry), stored atomically so that it survives a restart,
// and applied only between runs, with the collision thresholds it carries. A load that fails at any
// point, or never ends, leaves the model in use as it was.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "delta/controller/model_record.hpp"
#include "fw/controller.hpp"
#include "fw_linux/config.hpp"

namespace fw_linux {

class FeedForwardSlot {
 public:
  using Fault = delta::controller::ModelRecordFault;

  // The configuration's feed-forward (feed_forward, feed_forward.model),
  // then the store (feed_forward.store): a model loaded over the bus before
  // a restart, where there is one and it fits this robot.
  FeedForwardSlot(const PortConfig& c, const fw::ControllerConfig& core);

  // What start-up found, for delta_fw's start line: where the model in use
  // comes from, or why the store was not used.
  const std::string& startup_note() const { return startup_note_; }
  const fw::FeedForwardConfig& current() const { return current_; }
  std::uint32_t fit_id() const { return fit_id_; }
  // The model in use as a record; empty: none.
  std::span<const std::uint8_t> record() const;
  // The collision thresholds of the model in use, where it carries them.
  const std::optional<fw::CollisionThresholds>& thresholds() const { return thresholds_; }
  Fault last_load() const { return last_load_; }

  // How a change reaches the controller (Controller::set_feed_forward,
  // and the detector's thresholds): false when it refused (a run is on).
  using Apply = std::function<bool(const fw::FeedForwardConfig&,
                                   const std::optional<fw::CollisionThresholds>&)>;
  void set_apply(Apply apply) { apply_ = std::move(apply); }
  // Whether the controller's settings take a change at all (kOk, or why
  // not: the detector that collision.detect = true insists on), asked
  // before anything is stored or applied.
  using Check = std::function<Fault(const fw::FeedForwardConfig&,
                                    const std::optional<fw::CollisionThresholds>&)>;
  void set_check(Check check) { check_ = std::move(check); }
  // Where each load and mode change over the bus, taken or refused, is
  // said (delta_fw's log); none where unset.
  using Report = std::function<void(const std::string&)>;
  void set_report(Report report) { report_ = std::move(report); }

  // A whole record written to 0x2200:1: checked, stored, applied (the mode
  // becomes model). Anything but kOk leaves the model in use as it was.
  Fault load(std::span<const std::uint8_t> bytes, bool between_runs);
  // 0x2200:3: 0 off, 1 nominal, 2 model (needs a model); until restart.
  Fault set_mode(std::uint32_t mode, bool between_runs);
  // A download refused before it became a record (longer than any).
  void note_refused_download(const std::string& why) const;

 private:
  Fault apply(const fw::FeedForwardConfig& next,
              const std::optional<fw::CollisionThresholds>& thresholds, bool between_runs);
  void keep(std::span<const std::uint8_t> bytes, const delta::controller::ModelRecord& r);
  void report_load(Fault f, std::uint32_t fit_id) const;

  fw::GeometryQ geometry_;
  std::string store_path_;
  fw::FeedForwardConfig current_{};
  std::uint32_t fit_id_{0};
  delta::controller::ModelRecordBytes record_{};
  std::size_t record_bytes_{0};  // 0: none
  std::optional<fw::CollisionThresholds> thresholds_;
  Fault last_load_{Fault::kOk};
  std::string startup_note_;
  Apply apply_;
  Check check_;
  Report report_;
};

}  // namespace fw_linux
