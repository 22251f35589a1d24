// host_id sdo read|write: one object of a CANopen node by SDO over
// SocketCAN (docs/protocol.md): expedited, segmented or block transfer.
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
#include "host_id/sdo_values.hpp"

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
  bool quiet{false};  // no transfer line
  bool json{false};   // the object, value and transfer as JSON
};

// A value the command line gave that is not what its type says: a usage
// error (exit status 2).
template <class F>
auto as_usage(F f) {
  try {
    return f();
  } catch (const UsageError&) {
    throw;
  } catch (const delta::InputError& e) {
    throw UsageError(e.what());
  }
}

// What `sdo write` sends: the file's bytes, or the VALUE encoded as --type.
std::vector<std::uint8_t> bytes_to_write(const SdoOptions& o) {
  if (!o.file.empty() == !o.value.empty()) {
    throw UsageError("sdo write: give a VALUE (with --type) or --file, one of them");
  }
  if (!o.file.empty()) {
    std::ifstream in(o.file, std::ios::binary);
    if (!in) throw delta::InputError("sdo write: " + o.file + ": cannot open");
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  if (o.type == "auto") throw UsageError("sdo write: --type is needed with a VALUE");
  return as_usage([&] { return encode_value(o.type, o.value); });
}

// A transfer that succeeded: the value read (or, with --json, the
// transfer as JSON) on stdout, and the transfer's size and speed on stderr
// unless --quiet.
void print_transfer(const SdoOptions& o, const Multiplexer& m, bool write,
                    const std::vector<std::uint8_t>& bytes, const delta::can::SdoOutcome& outcome,
                    CommandContext& context) {
  const double seconds = static_cast<double>(outcome.elapsed_us) * 1e-6;
  if (o.json) {
    char object[16];
    std::snprintf(object, sizeof object, "0x%04X:%02X", m.index, m.subindex);
    nlohmann::json j{
        {"node", o.node},     {"object", object},
        {"written", write},   {"bytes", outcome.bytes},
        {"seconds", seconds}, {"frames", outcome.frames_sent + outcome.frames_received}};
    if (!write && o.file.empty()) j["value"] = decode_value(o.type, bytes);
    if (!o.file.empty()) j["file"] = o.file;
    context.out << j.dump(2) << "\n";
    return;
  }
  if (!write && o.file.empty()) context.out << decode_value(o.type, bytes) << "\n";
  if (o.quiet) return;
  context.err << "host_id: " << outcome.bytes << " bytes " << (write ? "written" : "read") << " in "
              << outcome.frames_sent + outcome.frames_received << " frames, " << seconds << " s";
  if (outcome.bytes >= 1024 && seconds > 0) {
    context.err << " (" << static_cast<double>(outcome.bytes) / seconds / 1024.0 << " kB/s)";
  }
  context.err << "\n";
}

void run_sdo(const SdoOptions& o, bool write, CommandContext& context) {
  const Multiplexer m = as_usage([&] { return parse_object(o.object); });
  if (o.node < 1 || o.node > 127) throw UsageError("sdo: --node must be from 1 to 127");
  std::vector<std::uint8_t> bytes;
  if (write) {
    bytes = bytes_to_write(o);
  } else if (o.type != "auto") {
    as_usage([&] {
      check_value_type(o.type);
      return 0;
    });
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
    context.err << "host_id sdo: error: " << channel.describe(m.index, m.subindex, outcome) << "\n";
    context.exit_code = outcome.by_server ? kExitSdoAborted : kExitNoAnswer;
    return;
  }
  if (!write && !o.file.empty()) {
    delta::write_file_atomically(o.file, std::string(bytes.begin(), bytes.end()));
  }
  print_transfer(o, m, write, bytes, outcome, context);
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
  c->add_flag("--quiet", o.quiet, "no line about the transfer (errors stay)");
  c->add_flag("--json", o.json, "the object, value and transfer as JSON on stdout");
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
  r->add_option("-o,--out", read->file, "write the bytes to this file (atomically)")
      ->check(kOutputPath);
  r->callback([read, &context] { run_sdo(*read, false, context); });
  auto write = std::make_shared<SdoOptions>();
  CLI::App* w = c->add_subcommand("write", "write an object");
  add_common_options(w, *write);
  w->add_option("VALUE", write->value, "the value, as --type says");
  w->add_option("--file", write->file, "write this file's bytes instead of a VALUE");
  w->callback([write, &context] { run_sdo(*write, true, context); });
}

}  // namespace host_id
