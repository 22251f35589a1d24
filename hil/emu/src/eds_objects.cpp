#include "eds_objects.hpp"

#include <algorithm>
#include <array>
#include <cstring>

namespace emu {

namespace sdo = delta::can::sdo;
namespace co = delta::canopen;

EdsObjects::EdsObjects(const co::Eds& eds, std::uint8_t node,
                       std::vector<sdo::ObjectDictionary*> behaviours)
    : eds_(eds), node_(node) {
  for (const auto& [key, v] : eds.variables) {
    sdo::ObjectInfo info;
    sdo::ObjectDictionary* found = nullptr;
    for (sdo::ObjectDictionary* b : behaviours) {
      if (b->find(v.index, v.subindex, info) == sdo::kNoAbort) {
        found = b;
        break;
      }
    }
    if (found != nullptr && !v.opaque) {
      behaviour_[key] = found;
      continue;
    }
    // A value of its own: the default's bytes (a string's text).
    std::vector<std::uint8_t> bytes;
    if (v.size_bytes() != 0) {
      const std::uint64_t value = v.value(node).value_or(0);
      for (unsigned i = 0; i < v.size_bytes(); ++i)
        bytes.push_back(static_cast<std::uint8_t>(value >> (8 * i)));
    } else if (!v.opaque && v.data_type == co::data_type::kVisibleString) {
      bytes.assign(v.default_text.begin(), v.default_text.end());
    }
    stored_[key] = std::move(bytes);
  }
}

const co::EdsVariable* EdsObjects::variable(std::uint16_t index, std::uint8_t subindex,
                                            sdo::AbortCode& code) const {
  const co::EdsVariable* v = eds_.find(index, subindex);
  code = v != nullptr             ? sdo::kNoAbort
         : eds_.has_object(index) ? sdo::kAbortSubindexDoesNotExist
                                  : sdo::kAbortObjectDoesNotExist;
  return v;
}

sdo::AbortCode EdsObjects::find(std::uint16_t index, std::uint8_t subindex, sdo::ObjectInfo& info) {
  sdo::AbortCode code = sdo::kNoAbort;
  const co::EdsVariable* v = variable(index, subindex, code);
  if (v == nullptr) return code;
  const Key key{index, subindex};
  const bool fixed_size = v->size_bytes() != 0;
  if (const auto it = stored_.find(key); it != stored_.end()) {
    const auto size = static_cast<std::uint32_t>(it->second.size());
    info = {size, fixed_size ? size : 4096, co::readable(v->access), co::writable(v->access),
            !fixed_size};
    return sdo::kNoAbort;
  }
  sdo::ObjectInfo b;
  if (const sdo::AbortCode c = behaviour_.at(key)->find(index, subindex, b); c != sdo::kNoAbort) {
    return c;
  }
  info = b;
  if (fixed_size) info.size = info.capacity = v->size_bytes();
  info.readable = co::readable(v->access);
  info.writable = co::writable(v->access);
  return sdo::kNoAbort;
}

sdo::AbortCode EdsObjects::read(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                                std::span<std::uint8_t> out) {
  sdo::AbortCode code = sdo::kNoAbort;
  const co::EdsVariable* v = variable(index, subindex, code);
  if (v == nullptr) return code;
  if (!co::readable(v->access)) return sdo::kAbortWriteOnly;
  const Key key{index, subindex};
  if (const auto it = stored_.find(key); it != stored_.end()) {
    if (offset + out.size() > it->second.size()) return sdo::kAbortNoData;
    if (!out.empty()) std::memcpy(out.data(), it->second.data() + offset, out.size());
    return sdo::kNoAbort;
  }
  // The behaviour's value in its own size, cut or extended to the EDS's.
  sdo::ObjectDictionary& b = *behaviour_.at(key);
  sdo::ObjectInfo info;
  if (const sdo::AbortCode c = b.find(index, subindex, info); c != sdo::kNoAbort) return c;
  if (info.variable_length) return b.read(index, subindex, offset, out);
  std::array<std::uint8_t, 8> value{};
  const std::uint32_t n = std::min<std::uint32_t>(info.size, 8);
  if (const sdo::AbortCode c = b.read(index, subindex, 0, std::span(value).first(n));
      c != sdo::kNoAbort) {
    return c;
  }
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = offset + i < 8 ? value[offset + i] : 0;
  return sdo::kNoAbort;
}

sdo::AbortCode EdsObjects::write(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                                 std::span<const std::uint8_t> data, bool last) {
  sdo::AbortCode code = sdo::kNoAbort;
  const co::EdsVariable* v = variable(index, subindex, code);
  if (v == nullptr) return code;
  if (!co::writable(v->access)) return sdo::kAbortReadOnly;
  const Key key{index, subindex};
  const auto behaviour = behaviour_.find(key);
  if (behaviour != behaviour_.end()) {
    const sdo::AbortCode c = behaviour->second->write(index, subindex, offset, data, last);
    // Writable in the EDS, read-only in the emulation: kept as a value.
    if (c != sdo::kAbortReadOnly) return c;
    behaviour_.erase(behaviour);
    stored_[key].assign(v->size_bytes(), 0);
  }
  if (offset == 0) staged_.clear();
  staged_.insert(staged_.end(), data.begin(), data.end());
  if (last) stored_[key] = staged_;
  return sdo::kNoAbort;
}

void EdsObjects::download_abandoned(std::uint16_t index, std::uint8_t subindex) {
  if (const auto it = behaviour_.find({index, subindex}); it != behaviour_.end()) {
    it->second->download_abandoned(index, subindex);
  }
  staged_.clear();
}

bool EdsObjects::mappable(std::uint16_t index, std::uint8_t subindex) const {
  const co::EdsVariable* v = eds_.find(index, subindex);
  return v != nullptr && v->pdo_mappable && !v->opaque;
}

void EdsObjects::apply_defaults() {
  for (const auto& [key, b] : behaviour_) {
    const co::EdsVariable& v = eds_.variables.at(key);
    const bool pdo_object = key.first >= 0x1400 && key.first < 0x1C00;
    if (pdo_object || key.first == 0x6040 || !co::writable(v.access) || v.size_bytes() == 0) {
      continue;
    }
    const auto value = v.value(node_);
    if (!value) continue;
    std::array<std::uint8_t, 8> bytes{};
    for (unsigned i = 0; i < 8; ++i) bytes[i] = static_cast<std::uint8_t>(*value >> (8 * i));
    (void)b->write(key.first, key.second, 0, std::span(bytes).first(v.size_bytes()), true);
  }
}

}  // namespace emu
