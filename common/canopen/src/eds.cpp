#include "delta/canopen/eds.hpp"

#include <ini.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <string_view>
#include <vector>

namespace delta::canopen {

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string hex4(std::uint32_t v) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%04X", v);
  return b;
}

// Whether text is well-formed UTF-8 (no overlong forms, no surrogates).
bool valid_utf8(std::string_view text) {
  std::size_t i = 0;
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    const std::size_t n = c < 0x80           ? 1
                          : (c >> 5) == 0x6  ? 2
                          : (c >> 4) == 0xE  ? 3
                          : (c >> 3) == 0x1E ? 4
                                             : 0;
    if (n == 0 || i + n > text.size()) return false;
    std::uint32_t cp = n == 1 ? c : c & (0x7F >> n);
    for (std::size_t k = 1; k < n; ++k) {
      const auto d = static_cast<unsigned char>(text[i + k]);
      if ((d >> 6) != 0x2) return false;
      cp = cp << 6 | (d & 0x3F);
    }
    static constexpr std::uint32_t kLeast[] = {0, 0, 0x80, 0x800, 0x10000};
    if (cp < kLeast[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += n;
  }
  return true;
}

// Latin-1 (ISO 8859-1) text as UTF-8: each byte is its code point.
std::string latin1_to_utf8(std::string_view text) {
  std::string out;
  out.reserve(text.size() + text.size() / 8);
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x80) {
      out += ch;
    } else {
      out += static_cast<char>(0xC0 | c >> 6);
      out += static_cast<char>(0x80 | (c & 0x3F));
    }
  }
  return out;
}

// What inih handed over: per section (lower case), per key (lower case),
// the value and its line.
struct Value {
  std::string text;
  int line{0};
};
struct Section {
  std::map<std::string, Value> keys;
  int line{0};  // of its first key
};

struct Collector {
  std::string_view text;
  std::size_t pos{0};
  int line{0};
  std::map<std::string, Section> sections;
  std::string error;  // the first problem found while reading
};

// inih's reader: one line at a time, counting lines, so that every key
// knows where it was written.
char* read_line(char* out, int size, void* stream) {
  auto& c = *static_cast<Collector*>(stream);
  if (c.pos >= c.text.size() || !c.error.empty()) return nullptr;
  std::size_t end = c.text.find('\n', c.pos);
  end = end == std::string_view::npos ? c.text.size() : end + 1;
  ++c.line;
  if (end - c.pos > static_cast<std::size_t>(size - 1)) {
    c.error = std::to_string(c.line) + ": the line is longer than " + std::to_string(size - 2) +
              " characters";
    return nullptr;
  }
  std::memcpy(out, c.text.data() + c.pos, end - c.pos);
  out[end - c.pos] = '\0';
  c.pos = end;
  return out;
}

int on_key(void* user, const char* section, const char* name, const char* value) {
  auto& c = *static_cast<Collector*>(user);
  Section& s = c.sections[lower(section)];
  if (s.keys.empty()) s.line = c.line;
  const std::string key = lower(name);
  if (s.keys.count(key) != 0 && c.error.empty()) {
    c.error = std::to_string(c.line) + ": [" + section + "] " + name + " is given twice (line " +
              std::to_string(s.keys[key].line) + " and here)";
    return 0;
  }
  s.keys[key] = Value{value, c.line};
  return 1;
}

// CiA 301's manufacturer-specific profile area.
constexpr bool manufacturer_object(std::uint16_t index) {
  return index >= 0x2000 && index <= 0x5FFF;
}

class Reader {
 public:
  Reader(const std::string& name, std::map<std::string, Section> sections)
      : name_(name), sections_(std::move(sections)) {}

  [[noreturn]] void fail(int line, const std::string& what) const {
    throw EdsError(name_ + ":" + std::to_string(line) + ": " + what);
  }

  const Section* section(const std::string& s) const {
    const auto it = sections_.find(s);
    return it == sections_.end() ? nullptr : &it->second;
  }

  std::int64_t number(const std::string& section_name, const std::string& key,
                      const Value& v) const {
    const std::optional<std::int64_t> n = parse_eds_number(v.text, 0);
    if (!n) {
      fail(v.line, "[" + section_name + "] " + key + "=" + v.text +
                       ": not a number (decimal, 0x hexadecimal or 0 octal)");
    }
    return *n;
  }

  const Value& required(const Section& s, const std::string& section_name,
                        const std::string& key) const {
    const auto it = s.keys.find(lower(key));
    if (it == s.keys.end()) fail(s.line, "[" + section_name + "] has no " + key);
    return it->second;
  }

  EdsIdentity identity() const {
    const Section* s = section("deviceinfo");
    if (s == nullptr) fail(1, "no [DeviceInfo] section");
    EdsIdentity id;
    const auto u32 = [&](const char* key) -> std::optional<std::uint32_t> {
      const auto it = s->keys.find(lower(key));
      if (it == s->keys.end()) return std::nullopt;
      const std::int64_t n = number("DeviceInfo", key, it->second);
      if (n < 0 || n > 0xFFFFFFFFll) {
        fail(it->second.line, std::string(key) + " is not an UNSIGNED32");
      }
      return static_cast<std::uint32_t>(n);
    };
    id.vendor_id = u32("VendorNumber");
    id.product_code = u32("ProductNumber");
    id.revision = u32("RevisionNumber");
    if (const auto it = s->keys.find("vendorname"); it != s->keys.end())
      id.vendor_name = it->second.text;
    if (const auto it = s->keys.find("productname"); it != s->keys.end()) {
      id.product_name = it->second.text;
    }
    return id;
  }

  // The indices an object list names, with the line naming each.
  std::vector<std::pair<std::uint16_t, int>> listed(const std::string& list) const {
    std::vector<std::pair<std::uint16_t, int>> out;
    const Section* s = section(lower(list));
    if (s == nullptr) return out;
    const Value& count_value = required(*s, list, "SupportedObjects");
    const std::int64_t count = number(list, "SupportedObjects", count_value);
    if (count < 0 || count > 0xFFFF) fail(count_value.line, "SupportedObjects out of range");
    for (std::int64_t i = 1; i <= count; ++i) {
      const auto it = s->keys.find(std::to_string(i));
      if (it == s->keys.end()) {
        fail(count_value.line, "[" + list + "] SupportedObjects=" + std::to_string(count) +
                                   " but there is no entry " + std::to_string(i));
      }
      const std::int64_t index = number(list, std::to_string(i), it->second);
      if (index < 1 || index > 0xFFFF) fail(it->second.line, "object index out of range");
      out.emplace_back(static_cast<std::uint16_t>(index), it->second.line);
    }
    return out;
  }

  static Access access(std::string_view text, bool& ok) {
    const std::string a = lower(text);
    ok = true;
    if (a == "ro") return Access::kReadOnly;
    if (a == "wo") return Access::kWriteOnly;
    if (a == "rw") return Access::kReadWrite;
    if (a == "rwr") return Access::kReadWriteRead;
    if (a == "rww") return Access::kReadWriteWrite;
    if (a == "const") return Access::kConst;
    ok = false;
    return Access::kReadOnly;
  }

  EdsVariable variable(const Section& s, const std::string& name, std::uint16_t index,
                       std::uint8_t sub) const {
    EdsVariable v;
    v.index = index;
    v.subindex = sub;
    v.line = s.line;
    v.name = required(s, name, "ParameterName").text;
    const Value& type = required(s, name, "DataType");
    const std::int64_t t = number(name, "DataType", type);
    if (t < 0 || t > 0xFFFF)
      fail(type.line, "[" + name + "] DataType=" + type.text + ": not a type");
    resolve_type(v, static_cast<std::uint16_t>(t), name, type);
    const Value& access_value = required(s, name, "AccessType");
    bool ok = false;
    v.access = access(access_value.text, ok);
    if (!ok) {
      fail(access_value.line, "[" + name + "] AccessType=" + access_value.text +
                                  ": not one of ro, wo, rw, rwr, rww, const");
    }
    if (const auto it = s.keys.find("pdomapping"); it != s.keys.end()) {
      const std::int64_t m = number(name, "PDOMapping", it->second);
      if (m != 0 && m != 1) fail(it->second.line, "[" + name + "] PDOMapping must be 0 or 1");
      v.pdo_mappable = m == 1;
    }
    if (const auto it = s.keys.find("defaultvalue"); it != s.keys.end()) {
      v.default_text = it->second.text;
      check_default(v, name, it->second);
    }
    if (const auto it = s.keys.find("parametervalue"); it != s.keys.end()) {
      v.parameter_text = it->second.text;
      check_default(v, name, it->second);
    }
    return v;
  }

  // A basic type as it is; a DEFTYPE of one that this file defines as its
  // base; anything else opaque, with a note.
  void resolve_type(EdsVariable& v, std::uint16_t code, const std::string& name,
                    const Value& type) const {
    v.declared_type = code;
    v.data_type = code;
    if (data_type_size(code)) return;
    if (const auto base = deftypes_.find(code); base != deftypes_.end()) {
      v.data_type = base->second;
      return;
    }
    v.opaque = true;
    char text[160];
    std::snprintf(text, sizeof text, ":%d: [%s] DataType=0x%04X is ", type.line, name.c_str(),
                  code);
    notes_.push_back(name_ + text +
                     (defstructs_.count(code) ? std::string("a DEFSTRUCT of this file")
                                              : std::string("not a basic type nor a DEFTYPE of "
                                                            "one in this file")) +
                     ": kept as opaque (its size is not known)");
  }

  void check_default(const EdsVariable& v, const std::string& name, const Value& value) const {
    if (v.opaque) return;
    const std::uint32_t size = v.size_bytes();
    const bool real = v.data_type == data_type::kReal32 || v.data_type == data_type::kReal64;
    if (size == 0 || real || value.text.empty()) return;
    const std::optional<std::int64_t> n = parse_eds_number(value.text, 1);
    if (!n) fail(value.line, "[" + name + "] DefaultValue=" + value.text + ": not a number");
    if (size >= 8) return;
    const std::int64_t unsigned_max = (std::int64_t{1} << (8 * size)) - 1;
    const std::int64_t signed_min = -(std::int64_t{1} << (8 * size - 1));
    const std::int64_t min = data_type_signed(v.data_type) ? signed_min : 0;
    if (*n < min || *n > unsigned_max) {
      fail(value.line, "[" + name + "] DefaultValue=" + value.text + " does not fit " +
                           std::string(data_type_name(v.data_type)));
    }
  }

  void object(Eds& eds, std::uint16_t index, int listed_line) const {
    char buf[8];
    std::snprintf(buf, sizeof buf, "%04x", index);
    const std::string name = buf;
    const Section* s = section(name);
    if (s == nullptr) {
      fail(listed_line, "object " + hex4(index) + " is listed but has no [" + name + "] section");
    }
    std::int64_t type = 0x7;
    if (const auto it = s->keys.find("objecttype"); it != s->keys.end()) {
      type = number(name, "ObjectType", it->second);
    }
    if ((type == 0x5 || type == 0x6) && index < 0x1000) return;  // a type definition
    if (type == 0x7 || type == 0x2) {
      eds.variables[{index, 0}] = variable(*s, name, index, 0);
      return;
    }
    if (type != 0x8 && type != 0x9) {
      fail(s->line, "[" + name + "] ObjectType=" + std::to_string(type) +
                        ": not VAR (0x7), ARRAY (0x8), RECORD (0x9) or DOMAIN (0x2); "
                        "DEFTYPE (0x5) and DEFSTRUCT (0x6) define types below 0x1000");
    }
    if (const auto it = s->keys.find("compactsubobj"); it != s->keys.end()) {
      return compact_array(eds, *s, name, index, it->second);
    }
    const Value& count_value = required(*s, name, "SubNumber");
    const std::int64_t count = number(name, "SubNumber", count_value);
    int found = 0;
    for (const SubSection& ss : sub_sections(name)) {
      eds.variables[{index, ss.sub}] = variable(*ss.section, std::string(ss.name), index, ss.sub);
      ++found;
    }
    if (found != count) {
      fail(count_value.line, "[" + name + "] SubNumber=" + std::to_string(count) + " but " +
                                 std::to_string(found) + " [" + name + "subN] sections");
    }
  }

  // The sections [XXXXsubN] of object XXXX (name), N from 0 to 0xFE in hex
  // as "%x" writes it, in the order of N: those that sort from "XXXXsub" on
  // and begin with it (not a look-up of all 255 names for every object).
  struct SubSection {
    std::uint8_t sub;
    std::string_view name;
    const Section* section;
  };
  std::vector<SubSection> sub_sections(const std::string& name) const {
    std::vector<SubSection> out;
    const std::string prefix = name + "sub";
    for (auto it = sections_.lower_bound(prefix);
         it != sections_.end() && it->first.compare(0, prefix.size(), prefix) == 0; ++it) {
      const std::string_view digits = std::string_view(it->first).substr(prefix.size());
      unsigned sub = 0;
      const auto [end, error] =
          std::from_chars(digits.data(), digits.data() + digits.size(), sub, 16);
      char canonical[16];
      std::snprintf(canonical, sizeof canonical, "%x", sub);
      if (error != std::errc() || end != digits.data() + digits.size() || sub > 0xFE ||
          digits != canonical) {
        continue;
      }
      out.push_back({static_cast<std::uint8_t>(sub), it->first, &it->second});
    }
    std::sort(out.begin(), out.end(),
              [](const SubSection& a, const SubSection& b) { return a.sub < b.sub; });
    return out;
  }

  // CiA 306's compact storage of an ARRAY: CompactSubObj=n sub-indices of
  // the section's DataType, AccessType and PDOMapping, their names in
  // [XXXXName] and values in [XXXXValue] (else the section's ParameterName
  // with the sub-index, and its DefaultValue); sub-index 0, UNSIGNED8
  // read-only, holds n.
  void compact_array(Eds& eds, const Section& s, const std::string& name, std::uint16_t index,
                     const Value& count_value) const {
    const std::int64_t n = number(name, "CompactSubObj", count_value);
    if (n < 1 || n > 0xFE) fail(count_value.line, "[" + name + "] CompactSubObj must be 1 to 254");
    EdsVariable count;
    count.index = index;
    count.line = s.line;
    count.name = "Number of entries";
    count.data_type = count.declared_type = data_type::kUnsigned8;
    count.access = Access::kReadOnly;
    count.default_text = std::to_string(n);
    eds.variables[{index, 0}] = count;
    const Section* names = section(name + "name");
    const Section* values = section(name + "value");
    for (int sub = 1; sub <= n; ++sub) {
      EdsVariable v = variable(s, name, index, static_cast<std::uint8_t>(sub));
      const std::string key = std::to_string(sub);
      if (names != nullptr && names->keys.count(key) != 0) {
        v.name = names->keys.at(key).text;
      } else {
        v.name += " " + key;
      }
      if (values != nullptr && values->keys.count(key) != 0) {
        v.default_text = values->keys.at(key).text;
        check_default(v, name + "Value", values->keys.at(key));
      }
      eds.variables[{index, static_cast<std::uint8_t>(sub)}] = v;
    }
  }

  // The data types this file defines (sections [0001]..[0FFF] with
  // ObjectType DEFTYPE 0x5 or DEFSTRUCT 0x6): a DEFTYPE's base type, where
  // it is a basic one.
  void read_type_definitions() {
    for (const auto& [name, s] : sections_) {
      if (name.size() != 4 || name.find_first_not_of("0123456789abcdef") != std::string::npos) {
        continue;
      }
      const auto code = static_cast<std::uint16_t>(std::stoul(name, nullptr, 16));
      const auto kind = s.keys.find("objecttype");
      if (code >= 0x1000 || kind == s.keys.end()) continue;
      const std::int64_t k = number(name, "ObjectType", kind->second);
      if (k == 0x6) defstructs_.insert(code);
      if (k != 0x5) continue;
      const auto base = s.keys.find("datatype");
      const std::optional<std::int64_t> b =
          base == s.keys.end() ? std::nullopt : parse_eds_number(base->second.text, 0);
      if (b && *b > 0 && *b <= 0xFFFF && data_type_size(static_cast<std::uint16_t>(*b))) {
        deftypes_[code] = static_cast<std::uint16_t>(*b);
      } else {
        defstructs_.insert(code);  // a DEFTYPE of no basic type: opaque like a structure
      }
    }
  }

  std::vector<std::string> take_notes() { return std::move(notes_); }

  // A DCF's [DeviceComissioning] (CiA 306's spelling): the node ID the
  // file was configured for, which its $NODEID values use.
  void commissioning(Eds& eds) const {
    const Section* s = section("devicecomissioning");
    if (s == nullptr) return;
    eds.dcf = true;
    if (const auto it = s->keys.find("nodeid"); it != s->keys.end()) {
      const std::int64_t n = number("DeviceComissioning", "NodeID", it->second);
      if (n < 1 || n > 127) fail(it->second.line, "[DeviceComissioning] NodeID must be 1 to 127");
      eds.node_id = static_cast<std::uint8_t>(n);
    }
  }

  // What check_eds_complete reads besides the objects.
  void keep_for_checks(Eds& eds) const {
    const auto keys = [](const Section& s) {
      std::map<std::string, EdsKey> out;
      for (const auto& [k, v] : s.keys) out[k] = {v.text, v.line};
      return out;
    };
    if (const Section* s = section("deviceinfo")) {
      eds.device_info = keys(*s);
      eds.device_info_line = s->line;
    }
    if (const Section* s = section("dummyusage")) eds.dummy_usage = keys(*s);
    for (const auto& [name, s] : sections_) {
      if (name.size() != 4 || name.find_first_not_of("0123456789abcdef") != std::string::npos) {
        continue;
      }
      eds.object_sections[static_cast<std::uint16_t>(std::stoul(name, nullptr, 16))] = s.line;
    }
  }

 private:
  std::string name_;
  std::map<std::string, Section> sections_;
  std::map<std::uint16_t, std::uint16_t> deftypes_;  // code -> basic base type
  std::set<std::uint16_t> defstructs_;
  mutable std::vector<std::string> notes_;
};

}  // namespace

std::optional<std::uint32_t> data_type_size(std::uint16_t type) {
  switch (type) {
    case data_type::kBoolean:
    case data_type::kInteger8:
    case data_type::kUnsigned8:
      return 1;
    case data_type::kInteger16:
    case data_type::kUnsigned16:
      return 2;
    case 0x0010:  // INTEGER24
    case 0x0016:  // UNSIGNED24
      return 3;
    case data_type::kInteger32:
    case data_type::kUnsigned32:
    case data_type::kReal32:
      return 4;
    case 0x0012:  // INTEGER40
    case 0x0018:  // UNSIGNED40
      return 5;
    case 0x0013:  // INTEGER48
    case 0x0019:  // UNSIGNED48
      return 6;
    case 0x0014:  // INTEGER56
    case 0x001A:  // UNSIGNED56
      return 7;
    case data_type::kInteger64:
    case data_type::kUnsigned64:
    case data_type::kReal64:
      return 8;
    case data_type::kVisibleString:
    case data_type::kOctetString:
    case data_type::kUnicodeString:
    case data_type::kDomain:
      return 0;
    default:
      return std::nullopt;
  }
}

bool data_type_signed(std::uint16_t type) {
  return type == data_type::kInteger8 || type == data_type::kInteger16 ||
         type == data_type::kInteger32 || type == data_type::kInteger64 ||
         (type >= 0x0010 && type <= 0x0014);
}

std::string_view data_type_name(std::uint16_t type) {
  switch (type) {
    case data_type::kBoolean:
      return "BOOLEAN";
    case data_type::kInteger8:
      return "INTEGER8";
    case data_type::kInteger16:
      return "INTEGER16";
    case data_type::kInteger32:
      return "INTEGER32";
    case data_type::kUnsigned8:
      return "UNSIGNED8";
    case data_type::kUnsigned16:
      return "UNSIGNED16";
    case data_type::kUnsigned32:
      return "UNSIGNED32";
    case 0x0010:
      return "INTEGER24";
    case 0x0016:
      return "UNSIGNED24";
    case data_type::kReal32:
      return "REAL32";
    case data_type::kVisibleString:
      return "VISIBLE_STRING";
    case data_type::kOctetString:
      return "OCTET_STRING";
    case data_type::kDomain:
      return "DOMAIN";
    case data_type::kInteger64:
      return "INTEGER64";
    case data_type::kUnsigned64:
      return "UNSIGNED64";
    default:
      return "a data type";
  }
}

std::optional<std::int64_t> parse_eds_number(std::string_view text, std::uint8_t node_id) {
  const auto trim = [](std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
  };
  text = trim(text);
  std::int64_t base = 0;
  const std::string l = lower(text);
  if (l.rfind("$nodeid", 0) == 0) {
    base = node_id;
    text = trim(text.substr(7));
    if (text.empty()) return base;
    if (text.front() != '+') return std::nullopt;
    text = trim(text.substr(1));
  } else if (const std::size_t plus = l.find("+$nodeid");
             plus != std::string::npos && plus + 8 == l.size()) {
    base = node_id;
    text = trim(text.substr(0, plus));
  }
  if (text.empty()) return std::nullopt;
  bool negative = false;
  if (text.front() == '-') {
    negative = true;
    text.remove_prefix(1);
  }
  int radix = 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    radix = 16;
    text.remove_prefix(2);
  } else if (text.size() > 1 && text[0] == '0') {
    radix = 8;
    text.remove_prefix(1);
  }
  if (text.empty() || text.size() > 20) return std::nullopt;
  std::uint64_t v = 0;
  for (const char ch : text) {
    const int c = std::tolower(static_cast<unsigned char>(ch));
    const int digit = std::isdigit(c) ? c - '0' : (c >= 'a' && c <= 'f' ? c - 'a' + 10 : 99);
    if (digit >= radix) return std::nullopt;
    if (v > (std::uint64_t{1} << 62)) return std::nullopt;
    v = v * static_cast<std::uint64_t>(radix) + static_cast<std::uint64_t>(digit);
  }
  const auto magnitude = static_cast<std::int64_t>(v);
  return base + (negative ? -magnitude : magnitude);
}

std::optional<std::uint64_t> EdsVariable::value(std::uint8_t node_id) const {
  if (parameter_text.empty()) return default_value(node_id);
  EdsVariable configured = *this;
  configured.default_text = parameter_text;
  return configured.default_value(node_id);
}

std::optional<std::uint64_t> EdsVariable::default_value(std::uint8_t node_id) const {
  const std::uint32_t size = size_bytes();
  if (size == 0 || default_text.empty()) return std::nullopt;
  const std::optional<std::int64_t> n = parse_eds_number(default_text, node_id);
  if (!n) return std::nullopt;
  const auto bits = static_cast<std::uint64_t>(*n);
  return size >= 8 ? bits : bits & ((std::uint64_t{1} << (8 * size)) - 1);
}

const EdsVariable* Eds::find(std::uint16_t index, std::uint8_t subindex) const {
  const auto it = variables.find({index, subindex});
  return it == variables.end() ? nullptr : &it->second;
}

bool Eds::has_object(std::uint16_t index) const {
  const auto it = variables.lower_bound({index, 0});
  return it != variables.end() && it->first.first == index;
}

Eds parse_eds(std::string_view raw, const std::string& name) {
  // Vendors write EDS files in Latin-1 as often as in UTF-8: a file that is
  // not valid UTF-8 is read as Latin-1, so that names and messages are text.
  const bool latin1 = !valid_utf8(raw);
  const std::string converted = latin1 ? latin1_to_utf8(raw) : std::string();
  const std::string_view text = latin1 ? std::string_view(converted) : raw;
  Collector c;
  c.text = text;
  const int status = ini_parse_stream(read_line, &c, on_key, &c);
  if (!c.error.empty()) throw EdsError(name + ":" + c.error);
  if (status > 0) {
    throw EdsError(name + ":" + std::to_string(status) +
                   ": not an INI line (expected [Section], Key=Value or a ; comment)");
  }
  Reader reader(name, std::move(c.sections));
  reader.read_type_definitions();
  Eds eds;
  eds.path = name;
  if (latin1) eds.notes.push_back(name + ":1: not UTF-8: read as Latin-1 (ISO 8859-1)");
  eds.identity = reader.identity();
  reader.commissioning(eds);
  for (const char* list : {"MandatoryObjects", "OptionalObjects", "ManufacturerObjects"}) {
    for (const auto& [index, line] : reader.listed(list)) {
      if (!manufacturer_object(index)) {
        reader.object(eds, index, line);
      } else {
        // The bring-up uses no manufacturer object: a malformed one is
        // left out with a note, so that the drive's real problems show.
        try {
          reader.object(eds, index, line);
        } catch (const EdsError& e) {
          const std::uint16_t dropped = index;  // a lambda cannot capture a binding (C++20)
          std::erase_if(eds.variables, [&](const auto& v) { return v.first.first == dropped; });
          eds.notes.push_back(std::string(e.what()) +
                              ": a manufacturer object (0x2000-0x5FFF), which the bring-up does "
                              "not use: left out");
          continue;
        }
      }
      eds.listed.push_back({index, list, line});
    }
  }
  reader.keep_for_checks(eds);
  for (std::string& note : reader.take_notes()) eds.notes.push_back(std::move(note));
  for (const auto& [index, what] : {std::pair<std::uint16_t, const char*>{0x1000, "device type"},
                                    {0x1001, "error register"},
                                    {0x1018, "identity"}}) {
    if (!eds.has_object(index)) {
      reader.fail(1, "no object " + hex4(index) + " (" + what + "), which CiA 301 makes mandatory");
    }
  }
  return eds;
}

Eds read_eds(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw EdsError(path + ": cannot open: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  return parse_eds(text.str(), path);
}

}  // namespace delta::canopen
