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
    mc::encode_model_record(r, record_);
    has_record_ = true;
    fit_id_ = r.fit_id;
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
  std::copy(bytes.begin(), bytes.end(), record_.begin());
  has_record_ = true;
  fit_id_ = r.fit_id;
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
  if (!has_record_) return {};
  return record_;
}

FeedForwardSlot::Fault FeedForwardSlot::apply(const fw::FeedForwardConfig& next,
                                              bool between_runs) {
  if (!between_runs || (apply_ && !apply_(next))) return Fault::kBusy;
  current_ = next;
  return Fault::kOk;
}

FeedForwardSlot::Fault FeedForwardSlot::load(std::span<const std::uint8_t> bytes,
                                             bool between_runs) {
  mc::ModelRecord r;
  Fault f = mc::decode_model_record(bytes, r);
  if (f == Fault::kOk && !mc::same_geometry_q(r.geometry, geometry_)) f = Fault::kGeometry;
  if (f == Fault::kOk && !between_runs) f = Fault::kBusy;
  if (f == Fault::kOk && !store_path_.empty()) {
    try {
      delta::write_file_atomically(
          store_path_, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    } catch (const std::exception&) {
      f = Fault::kNotStored;
    }
  }
  if (f == Fault::kOk) {
    fw::FeedForwardConfig next = current_;
    next.mode = fw::FeedForwardMode::kModel;
    next.model = delta::fx::prepare_model(geometry_, r.parameters);
    f = apply(next, between_runs);
  }
  if (f == Fault::kOk) {
    std::copy(bytes.begin(), bytes.end(), record_.begin());
    has_record_ = true;
    fit_id_ = r.fit_id;
  }
  last_load_ = f;
  return f;
}

FeedForwardSlot::Fault FeedForwardSlot::set_mode(std::uint32_t mode, bool between_runs) {
  if (mode > static_cast<std::uint32_t>(fw::FeedForwardMode::kModel)) return Fault::kValue;
  fw::FeedForwardConfig next = current_;
  next.mode = static_cast<fw::FeedForwardMode>(mode);
  if (next.mode == fw::FeedForwardMode::kModel && !has_record_) return Fault::kKind;
  return apply(next, between_runs);
}

}  // namespace fw_linux
