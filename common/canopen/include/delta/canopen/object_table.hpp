// A node's object dictionary as a table, behind common's SDO server: each
// scalar object with its size and how to read and (if writable) write it
// from the node's state, each visible string with how to read it, each
// write-only domain with where its bytes go as they arrive. Written
// once for the emulated drives and the controller's own node; the same
// table checks that the node's EDS describes it.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>

#include "delta/can/sdo.hpp"
#include "delta/canopen/eds.hpp"

namespace delta::canopen {

template <class Context>
class ObjectTable final : public can::sdo::ObjectDictionary {
 public:
  struct Scalar {
    std::uint16_t index;
    std::uint8_t subindex;
    std::uint8_t size;  // bytes, 1 to 4
    std::uint32_t (*get)(const Context&);
    // nullptr: read-only. Checks the value; an abort leaves the state as it was.
    can::sdo::AbortCode (*set)(Context&, std::uint32_t);
    bool pdo_mappable{false};
  };
  struct Text {  // a read-only VISIBLE_STRING
    std::uint16_t index;
    std::uint8_t subindex;
    std::string (*get)(const Context&);
  };

  struct Domain {  // a DOMAIN, streamed to the node (program data, a model)
    std::uint16_t index;
    std::uint8_t subindex;
    std::uint32_t (*capacity)(const Context&);  // the most one download may write
    // The download's bytes in order, the final piece with `last`.
    can::sdo::AbortCode (*write)(Context&, std::uint32_t offset, std::span<const std::uint8_t>,
                                 bool last);
    void (*abandoned)(Context&);  // the download ended without its last piece
    // Its current bytes for an upload; nullptr: write-only. An empty span
    // answers an upload with "no data available" (0x08000024).
    std::span<const std::uint8_t> (*contents)(const Context&){nullptr};
  };

  // The scalars in the order of index, then sub-index, each once: they are
  // looked up by binary search (every SDO transfer and every PDO entry of
  // every SYNC looks one up). Throws std::invalid_argument where they are not.
  ObjectTable(Context context, std::span<const Scalar> scalars, std::span<const Text> texts,
              std::span<const Domain> domains = {})
      : context_(context), scalars_(scalars), texts_(texts), domains_(domains) {
    const auto out_of_order = [](const Scalar& a, const Scalar& b) { return !before(a, b); };
    if (std::adjacent_find(scalars.begin(), scalars.end(), out_of_order) != scalars.end()) {
      throw std::invalid_argument("ObjectTable: the scalars are not in index order, each once");
    }
  }

  // The order of the scalars.
  static bool before(const Scalar& a, const Scalar& b) {
    return key(a.index, a.subindex) < key(b.index, b.subindex);
  }

  // Each looks among the scalars first, which are most of the objects and
  // all of those a PDO carries (an object is one of the three kinds).
  can::sdo::AbortCode find(std::uint16_t index, std::uint8_t subindex,
                           can::sdo::ObjectInfo& info) override {
    can::sdo::AbortCode code = can::sdo::kNoAbort;
    if (const Scalar* s = scalar(index, subindex, code)) {
      info = {s->size, s->size, true, s->set != nullptr, false};
      return can::sdo::kNoAbort;
    }
    if (const Text* t = text(index, subindex)) {
      info = {static_cast<std::uint32_t>(t->get(context_).size()), 0, true, false, true};
      return can::sdo::kNoAbort;
    }
    if (const Domain* d = domain(index, subindex)) {
      const auto size = d->contents ? static_cast<std::uint32_t>(d->contents(context_).size()) : 0u;
      info = {size, d->capacity(context_), d->contents != nullptr, true, true};
      return can::sdo::kNoAbort;
    }
    return code;
  }

  can::sdo::AbortCode read(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                           std::span<std::uint8_t> out) override {
    can::sdo::AbortCode code = can::sdo::kNoAbort;
    if (const Scalar* s = scalar(index, subindex, code)) {
      const std::uint32_t v = s->get(context_);
      for (std::size_t i = 0; i < out.size(); ++i) {
        out[i] = static_cast<std::uint8_t>(v >> (8 * (offset + i)));
      }
      return can::sdo::kNoAbort;
    }
    if (const Text* t = text(index, subindex)) {
      const std::string value = t->get(context_);
      if (offset + out.size() > value.size()) return can::sdo::kAbortNoData;  // it changed
      if (!out.empty()) std::memcpy(out.data(), value.data() + offset, out.size());
      return can::sdo::kNoAbort;
    }
    if (const Domain* d = domain(index, subindex)) {
      if (d->contents == nullptr) return can::sdo::kAbortWriteOnly;
      const std::span<const std::uint8_t> value = d->contents(context_);
      if (value.empty() || offset + out.size() > value.size()) return can::sdo::kAbortNoData;
      if (!out.empty()) std::memcpy(out.data(), value.data() + offset, out.size());
      return can::sdo::kNoAbort;
    }
    return code;
  }

  can::sdo::AbortCode write(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                            std::span<const std::uint8_t> data, bool last) override {
    can::sdo::AbortCode code = can::sdo::kNoAbort;
    const Scalar* s = scalar(index, subindex, code);
    if (s == nullptr) {
      if (const Domain* d = domain(index, subindex)) return d->write(context_, offset, data, last);
      return text(index, subindex) ? can::sdo::kAbortReadOnly : code;
    }
    if (s->set == nullptr) return can::sdo::kAbortReadOnly;
    if (offset == 0) staged_ = 0;
    for (std::size_t i = 0; i < data.size(); ++i) {
      staged_ |= std::uint32_t{data[i]} << (8 * (offset + i));
    }
    return last ? s->set(context_, staged_) : can::sdo::kNoAbort;
  }

  void download_abandoned(std::uint16_t index, std::uint8_t subindex) override {
    if (const Domain* d = domain(index, subindex)) d->abandoned(context_);
  }

  // Whether index:subindex may be mapped into a PDO.
  bool mappable(std::uint16_t index, std::uint8_t subindex) const {
    can::sdo::AbortCode code = can::sdo::kNoAbort;
    const Scalar* s = scalar(index, subindex, code);
    return s != nullptr && s->pdo_mappable;
  }

  // Where `eds` and this table disagree, both ways (an object one has and
  // the other not, a size, write access), in words with the EDS's line and
  // `node` for the node ("the emulated drive"); "" if they agree.
  std::string mismatch(const Eds& eds, const std::string& node) {
    char at[64];
    for (const auto& [key, v] : eds.variables) {
      std::snprintf(at, sizeof at, ":%d: 0x%04X:%02X (", v.line, v.index, v.subindex);
      const std::string where = eds.path + at + v.name + ")";
      can::sdo::ObjectInfo info;
      if (find(v.index, v.subindex, info) != can::sdo::kNoAbort)
        return where + " is not an object of " + node;
      if (v.size_bytes() != (info.variable_length ? 0 : info.size)) {
        return where + " has " + std::to_string(v.size_bytes()) + " bytes; " + node + "'s has " +
               std::to_string(info.size);
      }
      if (writable(v.access) != info.writable) {
        return where + (info.writable ? " is writable" : " is read-only") + " in " + node;
      }
      if (v.pdo_mappable != mappable(v.index, v.subindex)) {
        return where + (v.pdo_mappable ? " is not" : " is") + " PDO-mappable in " + node;
      }
    }
    const auto unlisted = [&](std::uint16_t index, std::uint8_t subindex) {
      std::snprintf(at, sizeof at, "0x%04X:%02X", index, subindex);
      return eds.path + ": " + node + " has object " + at + ", which the EDS does not list";
    };
    for (const Scalar& s : scalars_) {
      if (eds.find(s.index, s.subindex) == nullptr) return unlisted(s.index, s.subindex);
    }
    for (const Text& t : texts_) {
      if (eds.find(t.index, t.subindex) == nullptr) return unlisted(t.index, t.subindex);
    }
    for (const Domain& d : domains_) {
      if (eds.find(d.index, d.subindex) == nullptr) return unlisted(d.index, d.subindex);
    }
    return "";
  }

 private:
  const Text* text(std::uint16_t index, std::uint8_t subindex) const {
    for (const Text& t : texts_) {
      if (t.index == index && t.subindex == subindex) return &t;
    }
    return nullptr;
  }
  const Domain* domain(std::uint16_t index, std::uint8_t subindex) const {
    for (const Domain& d : domains_) {
      if (d.index == index && d.subindex == subindex) return &d;
    }
    return nullptr;
  }
  static std::uint32_t key(std::uint16_t index, std::uint8_t subindex) {
    return std::uint32_t{index} << 8 | subindex;
  }
  const Scalar* scalar(std::uint16_t index, std::uint8_t subindex,
                       can::sdo::AbortCode& code) const {
    code = can::sdo::kAbortObjectDoesNotExist;
    // The member read once: the sanitizers' build checks this object's type
    // on every access to a member.
    const std::span<const Scalar> all = scalars_;
    // The first scalar not before index:subindex.
    const std::uint32_t wanted = key(index, subindex);
    std::size_t first = 0, end = all.size();
    while (first < end) {
      const std::size_t mid = first + (end - first) / 2;
      if (key(all[mid].index, all[mid].subindex) < wanted) {
        first = mid + 1;
      } else {
        end = mid;
      }
    }
    if (first < all.size() && all[first].index == index && all[first].subindex == subindex) {
      code = can::sdo::kNoAbort;
      return &all[first];
    }
    // Another sub-index of the object sorts next to where this one would.
    if ((first < all.size() && all[first].index == index) ||
        (first > 0 && all[first - 1].index == index)) {
      code = can::sdo::kAbortSubindexDoesNotExist;
    }
    for (const Text& t : texts_) {
      if (t.index == index) code = can::sdo::kAbortSubindexDoesNotExist;
    }
    for (const Domain& d : domains_) {
      if (d.index == index) code = can::sdo::kAbortSubindexDoesNotExist;
    }
    return nullptr;
  }

  Context context_;
  std::span<const Scalar> scalars_;
  std::span<const Text> texts_;
  std::span<const Domain> domains_;
  std::uint32_t staged_{0};  // a download's bytes until its last piece
};

}  // namespace delta::canopen
