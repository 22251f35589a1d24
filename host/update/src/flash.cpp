#include "host_id/flash.hpp"

#include <chrono>
#include <cstdio>
#include <ostream>
#include <string>
#include <vector>

#include "delta/can/sdo_channel.hpp"
#include "delta/hex.hpp"
#include "delta/input_error.hpp"
#include "delta/update/image_file.hpp"

namespace host_id {

namespace sdo = delta::can::sdo;
namespace up = delta::update;
using delta::hex32;
using Clock = std::chrono::steady_clock;

std::string flash_status_text(std::uint32_t status) {
  static const char* const kCodes[] = {"no error",
                                       "no valid program",
                                       "data format unknown",
                                       "data format error or CRC error",
                                       "flash not cleared before write",
                                       "flash write error",
                                       "general address error",
                                       "flash secured (write access not allowed now)"};
  const unsigned code = (status >> 1) & 0x7F;
  std::string text = code < 8 ? kCodes[code] : "error code " + std::to_string(code);
  const unsigned verdict = (status >> 8) & 0xFF;
  if (verdict != 0 && verdict < up::kVerdictCount) {
    text += std::string(" (") + up::describe(static_cast<up::Verdict>(verdict)) + ")";
  }
  return text;
}

TargetCheck check_target(const up::ImageHeader& h, const NodeIdentity& node,
                         const FlashOptions& o) {
  TargetCheck out;
  if (up::check_identity(h, node.identity) != up::Verdict::kOk) {
    const std::string what =
        o.image + " is for vendor " + hex32(h.identity.vendor_id) + ", product " +
        hex32(h.identity.product_code) + "; node " + std::to_string(o.node) + " is vendor " +
        hex32(node.identity.vendor_id) + ", product " + hex32(node.identity.product_code);
    if (!o.force) throw FlashError{what + " (--force sends it anyway)", kExitFlashRefusedHere};
    out.warning = what + "; sending it as --force asks";
  }
  try {
    out.running = up::parse_version(node.version_text);
  } catch (const delta::InputError&) {
    out.running = {static_cast<std::uint16_t>(node.identity.revision >> 16),
                   static_cast<std::uint16_t>(node.identity.revision & 0xFFFF), 0};
  }
  if (up::compare(h.version, out.running) < 0 && !o.allow_downgrade) {
    throw FlashError{o.image + " holds version " + up::version_text(h.version) +
                         ", older than the running " + up::version_text(out.running) +
                         " (--allow-downgrade to flash it)",
                     kExitFlashRefusedHere};
  }
  return out;
}

namespace {

class ControllerSession {
 public:
  explicit ControllerSession(const FlashOptions& o)
      : node_(static_cast<std::uint8_t>(o.node)),
        socket_(
            delta::can::Socket::open(o.iface, {delta::can::sdo_response_filter(node_),
                                               {delta::can::protocol::kControllerHeartbeat.base_id,
                                                delta::can::protocol::kStandardIdMask, false}})),
        channel_(socket_, node_, std::chrono::milliseconds(o.timeout_ms)) {}

  delta::can::SdoChannel& channel() { return channel_; }

  // An unsigned object, or the failure as a FlashError.
  std::uint32_t read_u32(std::uint16_t index, std::uint8_t sub) {
    std::vector<std::uint8_t> bytes;
    const auto o = channel_.upload(index, sub, bytes, sdo::Transfer::kAuto, 4);
    if (!o.ok()) throw failure(index, sub, o);
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < bytes.size(); ++i) v |= std::uint32_t{bytes[i]} << (8 * i);
    return v;
  }
  std::string read_text(std::uint16_t index) {
    std::vector<std::uint8_t> bytes;
    const auto o = channel_.upload(index, 0, bytes, sdo::Transfer::kAuto, 256);
    if (!o.ok()) throw failure(index, 0, o);
    return {bytes.begin(), bytes.end()};
  }
  void write_u8(std::uint16_t index, std::uint8_t sub, std::uint8_t value) {
    const std::uint8_t bytes[] = {value};
    const auto o = channel_.download(index, sub, bytes, sdo::Transfer::kAuto);
    if (!o.ok()) throw failure(index, sub, o);
  }
  FlashError failure(std::uint16_t index, std::uint8_t sub, const delta::can::SdoOutcome& o) {
    std::string message = channel_.describe(index, sub, o);
    // The node discards the rest of a block it aborted (CiA 301 servers
    // may not; ours does), so the status can be read at once.
    std::vector<std::uint8_t> status;
    if (o.by_server && index >= 0x1F50 && index <= 0x1F57 &&
        channel_.upload(0x1F57, 1, status, sdo::Transfer::kAuto, 4).ok() && status.size() == 4) {
      message += "; flash status (0x1F57): " +
                 flash_status_text(std::uint32_t{status[0]} | std::uint32_t{status[1]} << 8 |
                                   std::uint32_t{status[2]} << 16 | std::uint32_t{status[3]} << 24);
    }
    return {message, o.by_server ? kExitFlashRefusedByController : kExitFlashNoAnswer};
  }
  // Whether the node sent its boot-up (heartbeat state 0) before `until`.
  bool await_boot_up(Clock::time_point until) {
    while (Clock::now() < until) {
      if (!socket_.wait_readable(std::chrono::milliseconds(50))) continue;
      while (auto r = socket_.receive()) {
        if (!r->error && r->frame.id == delta::can::protocol::kControllerHeartbeat.base_id &&
            r->frame.dlc >= 1 && r->frame.data[0] == 0) {
          return true;
        }
      }
    }
    return false;
  }

 private:
  std::uint8_t node_;
  delta::can::Socket socket_;
  delta::can::SdoChannel channel_;
};

// "[#########           ] 45 %  312.0 kB of 690.3 kB  41.2 kB/s" on one line.
void show_progress(std::ostream& err, std::uint32_t done, std::uint32_t total,
                   Clock::time_point start) {
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const unsigned width = 30;
  const unsigned filled =
      total == 0 ? width : static_cast<unsigned>(std::uint64_t{done} * width / total);
  char line[160];
  std::snprintf(line, sizeof line, "\r[%s%s] %3u %%  %.1f of %.1f kB  %.1f kB/s",
                std::string(filled, '#').c_str(), std::string(width - filled, ' ').c_str(),
                total == 0 ? 100u : static_cast<unsigned>(std::uint64_t{done} * 100 / total),
                done / 1024.0, total / 1024.0, seconds > 0 ? done / 1024.0 / seconds : 0.0);
  err << line << std::flush;
}

// Clear, then the block download; a transfer that fails on the bus (no
// answer, a timeout) starts over, up to --retries times. The outcome of the
// last attempt.
delta::can::SdoOutcome download(ControllerSession& s, const std::vector<std::uint8_t>& image,
                                const FlashOptions& o, std::ostream& err) {
  delta::can::SdoOutcome outcome;
  for (int attempt = 0; attempt <= o.retries; ++attempt) {
    s.write_u8(0x1F51, 1, 3);  // clear
    const auto start = Clock::now();
    auto last_shown = start;
    const auto total = static_cast<std::uint32_t>(image.size());
    s.channel().set_progress([&](std::uint32_t done) {
      if (o.quiet) return;
      if (Clock::now() - last_shown < std::chrono::milliseconds(200) && done != total) return;
      last_shown = Clock::now();
      show_progress(err, done, total, start);
    });
    outcome = s.channel().download(0x1F50, 1, image, sdo::Transfer::kBlock);
    s.channel().set_progress(nullptr);
    if (!o.quiet) err << "\n";
    if (outcome.ok() || outcome.by_server) return outcome;
    if (attempt < o.retries) {
      err << "host_id: the transfer failed (" << s.channel().describe(0x1F50, 1, outcome)
          << "); starting over (" << attempt + 1 << " of " << o.retries << " retries)\n";
    }
  }
  return outcome;
}

// After "start": the new program's boot-up, then its confirmation (0x2F00:1
// = 2) with the image's version; a roll-back shows as a reason in 0x2F00:2.
void await_confirmation(ControllerSession& s, const up::ImageHeader& h, const FlashOptions& o) {
  const auto until =
      Clock::now() + std::chrono::milliseconds(static_cast<long>(o.confirm_timeout_s * 1000));
  if (!s.await_boot_up(until)) {
    throw FlashError{"node " + std::to_string(o.node) + " did not restart within " +
                         std::to_string(o.confirm_timeout_s) + " s of the start command",
                     kExitFlashNotConfirmed};
  }
  while (Clock::now() < until) {
    try {
      const std::uint32_t rolled_back = s.read_u32(0x2F00, 2);
      if (rolled_back != 0) {
        throw FlashError{"the controller rolled the new program back (reason " +
                             std::to_string(rolled_back) + ", docs/flashing.md) and runs " +
                             s.read_text(0x100A) + " again",
                         kExitFlashNotConfirmed};
      }
      if (s.read_u32(0x2F00, 1) == 2 && s.read_text(0x100A) == up::version_text(h.version)) return;
    } catch (const FlashError& e) {
      if (e.exit_code == kExitFlashNotConfirmed) throw;  // else: not answering while it restarts
    }
    s.await_boot_up(Clock::now() + std::chrono::milliseconds(100));  // paces the polling
  }
  throw FlashError{
      "the new program did not confirm within " + std::to_string(o.confirm_timeout_s) + " s",
      kExitFlashNotConfirmed};
}

// The image, checked here: a failed check is refused unless --force.
up::CheckedImage checked_image(const FlashOptions& o, std::ostream& err) {
  up::CheckedImage image = up::read_image(o.image);
  if (image.verdict != up::Verdict::kOk) {
    const std::string what = o.image + ": " + up::describe(image.verdict);
    if (!o.force || !image.header) {
      throw FlashError{what + (image.header ? " (--force sends it anyway)" : ""),
                       kExitFlashRefusedHere};
    }
    err << "host_id flash: warning: " << what << "; sending it as --force asks\n";
  }
  return image;
}

// The first 4 bytes of a key, as 0x2F00:3 shows them.
std::uint32_t key_prefix(const up::PublicKey& k) {
  return std::uint32_t{k[0]} << 24 | std::uint32_t{k[1]} << 16 | std::uint32_t{k[2]} << 8 | k[3];
}

// A key image (docs/security.md): delta_boot takes it as soon as it is in,
// then restarts the program, which shows the new key in 0x2F00:3. Nothing
// is started; the version is not compared.
FlashReport flash_key_image(ControllerSession& session, const up::CheckedImage& image,
                            const TargetCheck& target, const FlashOptions& o, std::ostream& err) {
  const up::PublicKey next = *up::key_of(image);
  const std::uint32_t before = session.read_u32(0x2F00, 3);
  if (before == 0) {
    throw FlashError{"node " + std::to_string(o.node) +
                         " has no public key installed (0x2F00:3 = 0): a key image replaces one, "
                         "signed with it; the first key is installed on the controller "
                         "(delta_boot --public-key, docs/security.md)",
                     kExitFlashRefusedHere};
  }
  // No retry: the program restarts as soon as the key is in, and may not
  // answer the transfer's end; a retry would reach it under the new key.
  FlashOptions once = o;
  once.retries = 0;
  const delta::can::SdoOutcome sent = download(session, image.bytes, once, err);
  if (!sent.ok() && sent.by_server) throw session.failure(0x1F50, 1, sent);
  const auto until =
      Clock::now() + std::chrono::milliseconds(static_cast<long>(o.confirm_timeout_s * 1000));
  if (session.await_boot_up(until)) {
    for (int attempt = 0; attempt < 50; ++attempt) {
      try {
        if (session.read_u32(0x2F00, 3) == key_prefix(next)) {
          return {target.running,
                  target.running,
                  std::pair{before, key_prefix(next)},
                  image.bytes.size(),
                  static_cast<double>(sent.elapsed_us) * 1e-6,
                  sent.frames_sent};
        }
      } catch (const FlashError&) {  // not answering yet while it starts
      }
      session.await_boot_up(Clock::now() + std::chrono::milliseconds(100));  // paces the polling
    }
  }
  if (!sent.ok()) throw session.failure(0x1F50, 1, sent);  // nor did it take the key
  throw FlashError{"node " + std::to_string(o.node) +
                       " did not take the key (its program did not restart with it within " +
                       std::to_string(o.confirm_timeout_s) +
                       " s): delta_boot's log says why, e.g. an image not signed with the "
                       "installed key",
                   kExitFlashNotConfirmed};
}

}  // namespace

FlashReport flash_image(const FlashOptions& o, std::ostream& err) {
  const up::CheckedImage image = checked_image(o, err);
  const up::ImageHeader& h = *image.header;
  ControllerSession session(o);
  // An earlier flash that was killed mid-transfer may have left the node's
  // server in the transfer: end it now (CiA 301 abort, general error).
  session.channel().abort(0x1F50, 1, sdo::kAbortGeneral);
  const NodeIdentity node{
      {session.read_u32(0x1018, 1), session.read_u32(0x1018, 2), session.read_u32(0x1018, 3)},
      session.read_text(0x100A)};
  FlashOptions as_checked = o;
  as_checked.allow_downgrade = o.allow_downgrade || h.is_public_key();  // a key has no version
  const TargetCheck target = check_target(h, node, as_checked);
  if (target.warning) err << "host_id flash: warning: " << *target.warning << "\n";
  if (h.is_public_key()) {
    if (!up::key_of(image)) {
      throw FlashError{o.image + ": a key image whose payload is not a 32-byte key",
                       kExitFlashRefusedHere};
    }
    return flash_key_image(session, image, target, o, err);
  }
  if (!o.quiet) {
    err << "host_id: node " << o.node << " runs " << up::version_text(target.running)
        << "; sending " << o.image << " (version " << up::version_text(h.version) << ", "
        << image.bytes.size() << " bytes)\n";
  }
  const delta::can::SdoOutcome sent = download(session, image.bytes, o, err);
  if (!sent.ok()) throw session.failure(0x1F50, 1, sent);
  const std::uint32_t crc = session.read_u32(0x1F56, 1);
  if (crc != h.payload_crc32) {
    throw FlashError{"node " + std::to_string(o.node) + " holds a program with CRC-32 " +
                         hex32(crc) + ", the image's is " + hex32(h.payload_crc32),
                     kExitFlashVerifyFailed};
  }
  session.write_u8(0x1F51, 1, 1);  // start
  if (!o.quiet) {
    err << "host_id: verified (CRC-32 " << hex32(crc) << "); started; waiting for it to confirm\n";
  }
  await_confirmation(session, h, o);
  return {target.running,
          h.version,
          std::nullopt,
          image.bytes.size(),
          static_cast<double>(sent.elapsed_us) * 1e-6,
          sent.frames_sent};
}

}  // namespace host_id
