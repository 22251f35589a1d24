// Flashing the controller over CAN (CiA 302-3 program download,
// docs/flashing.md): the image and the node's identity and version checked
// first, block download with progress, the CRC verified, the new program
// started and its confirmation awaited. On any failure the old program
// keeps running.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>

#include "delta/can/protocol.hpp"
#include "delta/update/image.hpp"

namespace host_id {

struct FlashOptions {
  std::string image;
  std::string iface;
  int node{delta::can::protocol::kControllerNode};
  bool allow_downgrade{false};
  bool force{false};
  int retries{2};
  double confirm_timeout_s{60};
  int timeout_ms{1000};
  bool quiet{false};  // no progress and no step lines (warnings and errors stay)
};

// Exit statuses (docs/flashing.md). The old program runs on after each.
constexpr int kExitFlashRefusedByController = 3;  // the node aborted; 0x1F57 says why
constexpr int kExitFlashNoAnswer = 4;             // no answer, or the transfer failed
constexpr int kExitFlashRefusedHere = 5;          // the image is invalid, for other hardware, older
constexpr int kExitFlashVerifyFailed = 6;         // 0x1F56 is not the image's CRC-32
constexpr int kExitFlashNotConfirmed = 7;         // the new program rolled back or never confirmed

// A failed step: its message and exit status.
struct FlashError {
  std::string message;
  int exit_code;
};

// CiA 302-3's flash status (0x1F57) in words, with our verdict in its
// manufacturer byte where it has one.
std::string flash_status_text(std::uint32_t status);

// What the node says it is: its identity (0x1018:1..3) and the version text
// of the program it runs (0x100A).
struct NodeIdentity {
  delta::update::Identity identity;
  std::string version_text;
};

// What the checks of the node against the image decided.
struct TargetCheck {
  delta::update::Version running;      // the node's version
  std::optional<std::string> warning;  // a check that --force overrode
};

// The node's identity and version against the image's header: another
// product is refused unless --force (then a warning), an older version
// unless --allow-downgrade. A version text that does not parse is taken
// from the revision number (major.minor in its two halves). Throws
// FlashError (kExitFlashRefusedHere).
TargetCheck check_target(const delta::update::ImageHeader& image, const NodeIdentity& node,
                         const FlashOptions& o);

// What a flash did, for the closing line.
struct FlashReport {
  delta::update::Version running_before;
  delta::update::Version flashed;
  // A key image: the installed key's first 4 bytes before and after (0x2F00:3).
  std::optional<std::pair<std::uint32_t, std::uint32_t>> key_replaced;
  std::size_t bytes{0};
  double seconds{0};
  std::uint64_t frames_sent{0};
};

// Flashes o.image to node o.node on o.iface, with progress and warnings on
// err. Throws FlashError with the exit status of the step that failed, or
// delta::InputError for an image that cannot be read.
FlashReport flash_image(const FlashOptions& o, std::ostream& err);

}  // namespace host_id
