#include "host_id/sdo_values.hpp"

#include <charconv>
#include <cstdio>

#include "delta/input_error.hpp"

namespace host_id {

namespace {

struct TypeInfo {
  const char* name;
  unsigned size;  // 0: any length
  bool is_signed;
};
constexpr TypeInfo kTypes[] = {{"u8", 1, false},  {"u16", 2, false}, {"u32", 4, false},
                               {"i8", 1, true},   {"i16", 2, true},  {"i32", 4, true},
                               {"str", 0, false}, {"hex", 0, false}};

const TypeInfo& type_named(const std::string& name) {
  for (const TypeInfo& t : kTypes) {
    if (name == t.name) return t;
  }
  throw delta::InputError("sdo: --type " + name +
                          ": expected u8, u16, u32, i8, i16, i32, str or hex");
}

std::string hex_bytes(const std::vector<std::uint8_t>& bytes) {
  std::string s;
  char b[4];
  for (const std::uint8_t v : bytes) {
    std::snprintf(b, sizeof b, "%02X", v);
    if (!s.empty()) s += ' ';
    s += b;
  }
  return s;
}

}  // namespace

Multiplexer parse_object(const std::string& text) {
  const auto fail = [&]() -> Multiplexer {
    throw delta::InputError("sdo: object '" + text + "': expected INDEX[:SUB], e.g. 0x1018:1");
  };
  const std::size_t colon = text.find(':');
  std::string index = text.substr(0, colon);
  if (index.rfind("0x", 0) == 0 || index.rfind("0X", 0) == 0) index = index.substr(2);
  unsigned long i = 0;
  auto r = std::from_chars(index.data(), index.data() + index.size(), i, 16);
  if (index.empty() || r.ec != std::errc() || r.ptr != index.data() + index.size() || i > 0xFFFF) {
    return fail();
  }
  unsigned long s = 0;
  if (colon != std::string::npos) {
    std::string sub = text.substr(colon + 1);
    int base = 10;
    if (sub.rfind("0x", 0) == 0 || sub.rfind("0X", 0) == 0) {
      sub = sub.substr(2);
      base = 16;
    }
    r = std::from_chars(sub.data(), sub.data() + sub.size(), s, base);
    if (sub.empty() || r.ec != std::errc() || r.ptr != sub.data() + sub.size() || s > 0xFF) {
      return fail();
    }
  }
  return {static_cast<std::uint16_t>(i), static_cast<std::uint8_t>(s)};
}

void check_value_type(const std::string& type_name) {
  (void)type_named(type_name);
}

std::vector<std::uint8_t> encode_value(const std::string& type_name, const std::string& text) {
  const TypeInfo& t = type_named(type_name);
  if (t.name == std::string("str")) return {text.begin(), text.end()};
  if (t.name == std::string("hex")) {
    std::string digits;
    for (const char c : text) {
      if (c != ' ' && c != ':') digits += c;
    }
    if (digits.empty() || digits.size() % 2 != 0) {
      throw delta::InputError("sdo: '" + text + "' is not hexadecimal bytes (e.g. 01 A2 FF)");
    }
    std::vector<std::uint8_t> out;
    for (std::size_t i = 0; i < digits.size(); i += 2) {
      unsigned v = 0;
      const auto r = std::from_chars(digits.data() + i, digits.data() + i + 2, v, 16);
      if (r.ec != std::errc() || r.ptr != digits.data() + i + 2) {
        throw delta::InputError("sdo: '" + text + "' is not hexadecimal bytes (e.g. 01 A2 FF)");
      }
      out.push_back(static_cast<std::uint8_t>(v));
    }
    return out;
  }
  long long v = 0;
  const bool hex = text.rfind("0x", 0) == 0;
  const char* begin = text.data() + (hex ? 2 : 0);
  const auto r = std::from_chars(begin, text.data() + text.size(), v, hex ? 16 : 10);
  const long long lo = t.is_signed ? -(1ll << (8 * t.size - 1)) : 0;
  const long long hi = t.is_signed ? (1ll << (8 * t.size - 1)) - 1 : (1ll << (8 * t.size)) - 1;
  if (r.ec != std::errc() || r.ptr != text.data() + text.size() || v < lo || v > hi) {
    throw delta::InputError("sdo: '" + text + "' is not a " + t.name + " (" + std::to_string(lo) +
                            " to " + std::to_string(hi) + ")");
  }
  std::vector<std::uint8_t> out(t.size);
  for (unsigned i = 0; i < t.size; ++i)
    out[i] = static_cast<std::uint8_t>(static_cast<unsigned long long>(v) >> (8 * i));
  return out;
}

std::string decode_value(const std::string& type_name, const std::vector<std::uint8_t>& bytes) {
  std::string type = type_name;
  if (type == "auto") {
    bool printable = !bytes.empty();
    for (const std::uint8_t b : bytes) printable = printable && b >= 0x20 && b < 0x7F;
    // A number of 1, 2 or 4 bytes; bytes for 3 (there is no u24); text
    // where longer and printable; else bytes.
    static const char* const kBySize[] = {"hex", "u8", "u16", "hex", "u32"};
    type = bytes.size() <= 4 ? kBySize[bytes.size()] : (printable ? "str" : "hex");
  }
  const TypeInfo& t = type_named(type);
  if (type == "str") return std::string(bytes.begin(), bytes.end());
  if (type == "hex") return hex_bytes(bytes);
  if (bytes.size() != t.size) {
    throw delta::InputError("sdo: the object has " + std::to_string(bytes.size()) +
                            " bytes, not a " + t.name + " (" + hex_bytes(bytes) + ")");
  }
  unsigned long long u = 0;
  for (unsigned i = 0; i < t.size; ++i) u |= static_cast<unsigned long long>(bytes[i]) << (8 * i);
  long long v = static_cast<long long>(u);
  if (t.is_signed && (u >> (8 * t.size - 1)) != 0) v -= 1ll << (8 * t.size);
  char h[16];
  std::snprintf(h, sizeof h, "0x%0*llX", static_cast<int>(2 * t.size), u);
  return std::to_string(v) + " (" + h + ")";
}

}  // namespace host_id
