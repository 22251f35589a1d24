// check_eds_complete: what a CANopen tool needs of an EDS beyond what
// read_eds already refuses (CiA 306-1 v1.3, CiA 301 v4.2).
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "delta/canopen/eds.hpp"

namespace delta::canopen {

namespace {

std::string hex4(std::uint32_t v) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%04X", v);
  return b;
}

class Findings {
 public:
  explicit Findings(const Eds& eds) : eds_(eds) {}
  void add(int line, const std::string& what) {
    out_.push_back(eds_.path + ":" + std::to_string(line) + ": " + what);
  }
  std::vector<std::string> take() { return std::move(out_); }

 private:
  const Eds& eds_;
  std::vector<std::string> out_;
};

// [DeviceInfo]'s keys that CiA 306 requires (CompactPDO is optional).
constexpr const char* kDeviceInfoKeys[] = {
    "VendorName",        "VendorNumber",   "ProductName",
    "ProductNumber",     "RevisionNumber", "OrderCode",
    "BaudRate_10",       "BaudRate_20",    "BaudRate_50",
    "BaudRate_125",      "BaudRate_250",   "BaudRate_500",
    "BaudRate_800",      "BaudRate_1000",  "SimpleBootUpMaster",
    "SimpleBootUpSlave", "Granularity",    "DynamicChannelsSupported",
    "GroupMessaging",    "NrOfRXPDO",      "NrOfTXPDO",
    "LSS_Supported"};

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  return s;
}

// How many objects from `first` to `last` the EDS has.
unsigned objects_between(const Eds& eds, std::uint16_t first, std::uint16_t last) {
  unsigned n = 0;
  for (const auto& [index, line] : eds.object_sections) n += index >= first && index <= last;
  return n;
}

void check_device_info(const Eds& eds, Findings& f) {
  bool any_baud_rate = false;
  for (const char* key : kDeviceInfoKeys) {
    const auto it = eds.device_info.find(lower(key));
    if (it == eds.device_info.end()) {
      f.add(eds.device_info_line, std::string("[DeviceInfo] has no ") + key);
      continue;
    }
    const std::string k = key;
    const std::optional<std::int64_t> n = parse_eds_number(it->second.text, 0);
    const bool flag = k.rfind("BaudRate_", 0) == 0 || k == "SimpleBootUpMaster" ||
                      k == "SimpleBootUpSlave" || k == "DynamicChannelsSupported" ||
                      k == "GroupMessaging" || k == "LSS_Supported";
    if (flag && (!n || (*n != 0 && *n != 1))) {
      f.add(it->second.line, "[DeviceInfo] " + k + "=" + it->second.text + ": must be 0 or 1");
    }
    if (k.rfind("BaudRate_", 0) == 0 && n == 1) any_baud_rate = true;
    if (k == "Granularity" && (!n || *n < 0 || *n > 64)) {
      f.add(it->second.line, "[DeviceInfo] Granularity=" + it->second.text + ": must be 0 to 64");
    }
    const auto pdo_count = [&](const char* what, std::uint16_t first) {
      const unsigned have = objects_between(eds, first, static_cast<std::uint16_t>(first + 0x1FF));
      if (n && *n != have) {
        f.add(it->second.line, "[DeviceInfo] " + k + "=" + it->second.text + " but the EDS has " +
                                   std::to_string(have) + " " + what + " communication objects (" +
                                   hex4(first) + "..)");
      }
    };
    if (k == "NrOfRXPDO") pdo_count("RPDO", 0x1400);
    if (k == "NrOfTXPDO") pdo_count("TPDO", 0x1800);
  }
  if (!any_baud_rate) f.add(eds.device_info_line, "[DeviceInfo] supports no baud rate");
}

// The list an object belongs in.
std::string list_for(std::uint16_t index) {
  if (index == 0x1000 || index == 0x1001 || index == 0x1018) return "MandatoryObjects";
  if (index >= 0x2000 && index <= 0x5FFF) return "ManufacturerObjects";
  return "OptionalObjects";
}

void check_lists(const Eds& eds, Findings& f) {
  std::set<std::uint16_t> named;
  for (const EdsListing& l : eds.listed) {
    if (!named.insert(l.index).second) {
      f.add(l.line, "[" + l.list + "] names " + hex4(l.index) + ", which another entry names too");
    }
    if (l.list != list_for(l.index)) {
      f.add(l.line, "[" + l.list + "] names " + hex4(l.index) + ", which belongs in [" +
                        list_for(l.index) + "]");
    }
  }
  for (const auto& [index, line] : eds.object_sections) {
    if (named.count(index) == 0) {
      f.add(line, "object " + hex4(index) +
                      " has a section but no object list names it (add it to [" + list_for(index) +
                      "])");
    }
  }
}

// A PDO communication object without its mapping object, or the reverse.
void check_pdo_pairs(const Eds& eds, Findings& f) {
  for (const auto& [index, line] : eds.object_sections) {
    const bool rx_comm = index >= 0x1400 && index <= 0x15FF;
    const bool tx_comm = index >= 0x1800 && index <= 0x19FF;
    const bool rx_map = index >= 0x1600 && index <= 0x17FF;
    const bool tx_map = index >= 0x1A00 && index <= 0x1BFF;
    if (!(rx_comm || tx_comm || rx_map || tx_map)) continue;
    const auto other =
        static_cast<std::uint16_t>(rx_comm || tx_comm ? index + 0x200 : index - 0x200);
    if (eds.object_sections.count(other) == 0) {
      f.add(line, (rx_comm || tx_comm ? "PDO communication object " : "PDO mapping object ") +
                      hex4(index) + " has no " +
                      (rx_comm || tx_comm ? "mapping object " : "communication object ") +
                      hex4(other));
    }
  }
}

// Sub-index 0 of an ARRAY or RECORD says its highest sub-index; not in a
// PDO mapping object (the number of entries mapped) or the pre-defined
// error field 0x1003 (the number of errors).
bool counts_entries(std::uint16_t index) {
  return index == 0x1003 || (index >= 0x1600 && index <= 0x17FF) ||
         (index >= 0x1A00 && index <= 0x1BFF);
}

void check_highest_subindex(const Eds& eds, Findings& f) {
  std::map<std::uint16_t, unsigned> highest;
  for (const auto& [key, v] : eds.variables) {
    if (key.second > 0 && !counts_entries(key.first)) highest[key.first] = key.second;
  }
  for (const auto& [index, top] : highest) {
    const EdsVariable* sub0 = eds.find(index, 0);
    const int line = eds.object_sections.count(index) ? eds.object_sections.at(index) : 0;
    if (sub0 == nullptr) {
      f.add(line, "object " + hex4(index) + " has sub-indices but no sub-index 0");
      continue;
    }
    const std::optional<std::uint64_t> n = sub0->default_value(1);
    if (n && *n != top) {
      f.add(sub0->line, hex4(index) + ":00 says " + std::to_string(*n) +
                            " sub-indices, but the highest is " + std::to_string(top));
    }
  }
}

// A mapping entry: the object it names exists, is PDO-mappable (or a
// dummy the EDS says it uses), and has the length the entry says.
void check_mapping_entry(const Eds& eds, const EdsVariable& entry, std::uint64_t value,
                         unsigned& bits, Findings& f) {
  const auto index = static_cast<std::uint16_t>(value >> 16);
  const auto sub = static_cast<std::uint8_t>(value >> 8);
  const auto length = static_cast<unsigned>(value & 0xFF);
  bits += length;
  char at[32];
  std::snprintf(at, sizeof at, "0x%04X:%02X", entry.index, entry.subindex);
  char named[32];
  std::snprintf(named, sizeof named, "0x%04X:%02X", index, sub);
  std::uint32_t size = 0;
  if (index >= 0x0001 && index <= 0x0007) {
    char key[16];
    std::snprintf(key, sizeof key, "dummy%04x", index);
    const auto it = eds.dummy_usage.find(key);
    if (it == eds.dummy_usage.end() || parse_eds_number(it->second.text, 0) != 1) {
      f.add(entry.line, std::string(at) + " maps dummy " + hex4(index) +
                            ", which [DummyUsage] does not enable");
    }
    size = data_type_size(index).value_or(0);
  } else {
    const EdsVariable* v = eds.find(index, sub);
    if (v == nullptr) {
      f.add(entry.line, std::string(at) + " maps " + named + ", which the EDS does not have");
      return;
    }
    if (!v->pdo_mappable) {
      f.add(entry.line, std::string(at) + " maps " + named + ", which is not PDOMapping=1");
    }
    size = v->size_bytes();
  }
  if (size * 8 != length) {
    f.add(entry.line, std::string(at) + " maps " + named + " with " + std::to_string(length) +
                          " bits; it has " + std::to_string(size * 8));
  }
}

void check_mappings(const Eds& eds, Findings& f) {
  for (const auto& [index, line] : eds.object_sections) {
    const bool rx_map = index >= 0x1600 && index <= 0x17FF;
    const bool tx_map = index >= 0x1A00 && index <= 0x1BFF;
    if (!rx_map && !tx_map) continue;
    const EdsVariable* count = eds.find(index, 0);
    const std::optional<std::uint64_t> n = count ? count->default_value(1) : std::nullopt;
    if (!n) {
      f.add(line, "mapping object " + hex4(index) + " has no DefaultValue in sub-index 0");
      continue;
    }
    unsigned bits = 0;
    for (unsigned k = 1; k <= *n && k <= 0x40; ++k) {
      const EdsVariable* entry = eds.find(index, static_cast<std::uint8_t>(k));
      const std::optional<std::uint64_t> value = entry ? entry->default_value(1) : std::nullopt;
      if (!value) {
        f.add(count->line, hex4(index) + ":00 says " + std::to_string(*n) + " entries, but sub " +
                               std::to_string(k) + " has no DefaultValue");
        continue;
      }
      check_mapping_entry(eds, *entry, *value, bits, f);
    }
    if (bits > 64) {
      f.add(line, "mapping object " + hex4(index) + " maps " + std::to_string(bits) +
                      " bits, more than a CAN frame's 64");
    }
  }
}

}  // namespace

std::vector<std::string> check_eds_complete(const Eds& eds) {
  Findings f(eds);
  check_device_info(eds, f);
  check_lists(eds, f);
  check_pdo_pairs(eds, f);
  check_highest_subindex(eds, f);
  check_mappings(eds, f);
  return f.take();
}

}  // namespace delta::canopen
