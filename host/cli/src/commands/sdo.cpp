// host_id sdo read|write: one object of a CANopen node by SDO over
// SocketCAN (docs/protocol.md): expedited, segmented or block transfer.
#include <charconv>
#include <cstdio>
#include <fstream>
#include <memory>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include "commands/command.hpp"
#include "delta/atomic_file.hpp"
#include "delta/can/sdo_channel.hpp"

namespace host_id {

namespace {

namespace sdo = delta::can::sdo;

struct SdoOptions {
  std::string iface;
  int node{16};
  std::string object;  // INDEX[:SUB]
  std::string type{"auto"};
  std::string value;
  std::string file;  // write: the bytes to send; read: where to write them
  bool block{false};
  int timeout_ms{1000};
};

struct Multiplexer {
  std::uint16_t index;
  std::uint8_t subindex;
};

// "0x1018:1", "1018:0x01", "0x6041": the index in hexadecimal (as CANopen
// writes it), the sub-index decimal or 0x hexadecimal, 0 when absent.
Multiplexer parse_object(const std::string& text) {
  const auto fail = [&]() -> Multiplexer {
    throw UsageError("sdo: object '" + text + "': expected INDEX[:SUB], e.g. 0x1018:1");
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
  throw UsageError("sdo: --type " + name + ": expected u8, u16, u32, i8, i16, i32, str or hex");
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

// The value to write as its little-endian bytes.
std::vector<std::uint8_t> encode(const std::string& type_name, const std::string& text) {
  const TypeInfo& t = type_named(type_name);
  if (t.name == std::string("str")) return {text.begin(), text.end()};
  if (t.name == std::string("hex")) {
    std::string digits;
    for (const char c : text) {
      if (c != ' ' && c != ':') digits += c;
    }
    if (digits.empty() || digits.size() % 2 != 0) {
      throw UsageError("sdo: '" + text + "' is not hexadecimal bytes (e.g. 01 A2 FF)");
    }
    std::vector<std::uint8_t> out;
    for (std::size_t i = 0; i < digits.size(); i += 2) {
      unsigned v = 0;
      const auto r = std::from_chars(digits.data() + i, digits.data() + i + 2, v, 16);
      if (r.ec != std::errc() || r.ptr != digits.data() + i + 2) {
        throw UsageError("sdo: '" + text + "' is not hexadecimal bytes (e.g. 01 A2 FF)");
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
    throw UsageError("sdo: '" + text + "' is not a " + t.name + " (" + std::to_string(lo) + " to " +
                     std::to_string(hi) + ")");
  }
  std::vector<std::uint8_t> out(t.size);
  for (unsigned i = 0; i < t.size; ++i)
    out[i] = static_cast<std::uint8_t>(static_cast<unsigned long long>(v) >> (8 * i));
  return out;
}

// What was read, as the type says (auto: a number up to 4 bytes, text when
// printable, else bytes).
std::string decode(const std::string& type_name, const std::vector<std::uint8_t>& bytes) {
  std::string type = type_name;
  if (type == "auto") {
    bool printable = !bytes.empty();
    for (const std::uint8_t b : bytes) printable = printable && b >= 0x20 && b < 0x7F;
    type = bytes.size() >= 1 && bytes.size() <= 4 ? "u" + std::to_string(8 * bytes.size())
           : printable                            ? "str"
                                                  : "hex";
    if (type == "u24") type = "hex";
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

void run_sdo(const SdoOptions& o, bool write, CommandContext& context) {
  const Multiplexer m = parse_object(o.object);
  if (o.node < 1 || o.node > 127) throw UsageError("sdo: --node must be from 1 to 127");
  std::vector<std::uint8_t> bytes;
  if (write) {
    if (!o.file.empty() == !o.value.empty()) {
      throw UsageError("sdo write: give a VALUE (with --type) or --file, one of them");
    }
    if (!o.file.empty()) {
      std::ifstream in(o.file, std::ios::binary);
      if (!in) throw delta::InputError("sdo write: " + o.file + ": cannot open");
      bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    } else {
      if (o.type == "auto") throw UsageError("sdo write: --type is needed with a VALUE");
      bytes = encode(o.type, o.value);
    }
  } else if (o.type != "auto") {
    (void)type_named(o.type);
  }
  const auto node = static_cast<std::uint8_t>(o.node);
  delta::can::Socket socket =
      delta::can::Socket::open(o.iface, {delta::can::sdo_response_filter(node)});
  delta::can::SdoChannel channel(socket, node, std::chrono::milliseconds(o.timeout_ms));
  const sdo::Transfer transfer = o.block ? sdo::Transfer::kBlock : sdo::Transfer::kAuto;
  const delta::can::SdoOutcome outcome =
      write ? channel.download(m.index, m.subindex, bytes, transfer)
            : channel.upload(m.index, m.subindex, bytes, transfer);
  if (!outcome.ok()) {
    context.err << "host_id: error: " << channel.describe(m.index, m.subindex, outcome) << "\n";
    context.exit_code = outcome.by_server ? kExitSdoAborted : kExitNoAnswer;
    return;
  }
  if (!write && !o.file.empty()) {
    delta::write_file_atomically(o.file, std::string(bytes.begin(), bytes.end()));
  } else if (!write) {
    context.out << decode(o.type, bytes) << "\n";
  }
  const double seconds = static_cast<double>(outcome.elapsed_us) * 1e-6;
  context.err << "host_id: " << outcome.bytes << " bytes " << (write ? "written" : "read") << " in "
              << outcome.frames_sent + outcome.frames_received << " frames, " << seconds << " s";
  if (outcome.bytes >= 1024 && seconds > 0) {
    context.err << " (" << static_cast<double>(outcome.bytes) / seconds / 1024.0 << " kB/s)";
  }
  context.err << "\n";
  context.exit_code = 0;
}

void add_common_options(CLI::App* c, SdoOptions& o) {
  c->add_option("--can", o.iface, "the CAN interface")->required();
  c->add_option("--node", o.node, "the node (the controller is 16)")->capture_default_str();
  c->add_option("OBJECT", o.object, "INDEX[:SUB], e.g. 0x1018:1")->required();
  c->add_option("--type", o.type, "u8, u16, u32, i8, i16, i32, str, hex (read: auto)")
      ->capture_default_str();
  c->add_flag("--block", o.block, "block transfer (CiA 301, with CRC)");
  c->add_option("--timeout-ms", o.timeout_ms, "how long to wait for each answer")
      ->check(CLI::Range(1, 60000))
      ->capture_default_str();
}

}  // namespace

void add_sdo_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "Reads or writes one object of a CANopen node over SocketCAN by SDO (CiA 301): "
      "expedited, segmented or, with --block, block transfer. Exit status 3: the node "
      "aborted the transfer (the abort code and its meaning are printed); 4: no answer.");
  c->require_subcommand(1);
  auto read = std::make_shared<SdoOptions>();
  CLI::App* r = c->add_subcommand("read", "read an object; prints its value");
  add_common_options(r, *read);
  r->add_option("-o,--out", read->file, "write the bytes to this file (atomically)");
  r->callback([read, &context] { run_sdo(*read, false, context); });
  auto write = std::make_shared<SdoOptions>();
  CLI::App* w = c->add_subcommand("write", "write an object");
  add_common_options(w, *write);
  w->add_option("VALUE", write->value, "the value, as --type says");
  w->add_option("--file", write->file, "write this file's bytes instead of a VALUE");
  w->callback([write, &context] { run_sdo(*write, true, context); });
}

}  // namespace host_id
