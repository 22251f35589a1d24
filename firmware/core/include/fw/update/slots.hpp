// The A/B program slots' state machine (docs/flashing.md). One slot holds
// the confirmed program that runs; the other receives a new image:
//
//   empty -> receiving -> staged -> trial -> confirmed (it becomes the active slot)
//                 |                     \--> reverted  (the active slot runs again)
//                 \-> empty (image refused, or the download cut short)
//
// The supervisor persists the record before it acts on it, so a power loss
// at any moment leaves the active slot bootable: a download cut short is
// forgotten, a trial that was launched and never confirmed is reverted
// ("power lost during trial"). No heap, no floating point: the same code
// runs in delta_boot on Linux and on a microcontroller's boot loader.
#pragma once

#include <array>
#include <cstdint>

#include "delta/update/image.hpp"

namespace fw::update {

using delta::update::Verdict;
using delta::update::Version;

enum class SlotState : std::uint8_t {
  kEmpty = 0,
  kReceiving = 1,
  kStaged = 2,
  kTrial = 3,
  kConfirmed = 4,
  kReverted = 5,
};
inline constexpr std::uint8_t kSlotStateCount = 6;

enum class RevertReason : std::uint8_t {
  kNone = 0,
  kNoConfirmation = 1,  // the trial did not confirm within the time allowed
  kExited = 2,          // the trial program exited before it confirmed
  kCrashed = 3,         // the trial program was killed by a signal
  kPowerLost = 4,       // the supervisor restarted during the trial
  kNotStartable = 5,    // the staged program could not be started
};
inline constexpr std::uint8_t kRevertReasonCount = 6;

struct Slot {
  SlotState state{SlotState::kEmpty};
  std::uint32_t crc32{0};  // the program's CRC-32 (0x1F56)
  Version version{};
};

struct BootRecord {
  std::uint8_t active{0};  // the confirmed slot that runs outside a trial
  std::array<Slot, 2> slots{};
  bool trial_started{false};  // the trial program has been launched
  RevertReason last_revert{RevertReason::kNone};
  Verdict last_verdict{Verdict::kOk};  // of the last download
};

// Why an event does not apply in the present state.
enum class Refusal : std::uint8_t {
  kNone,
  kTrialUnderWay,  // downloads, clears and starts wait for the trial's end
  kNothingStaged,  // start without a valid staged program
  kNotReceiving,   // a download's end without its beginning
  kNoTrial,        // confirm or fail without a trial
};

struct Launch {
  std::uint8_t slot{0};
  bool trial{false};
};

class Slots {
 public:
  explicit Slots(const BootRecord& r) : r_(r) {}
  const BootRecord& record() const { return r_; }
  std::uint8_t active() const { return r_.active; }
  std::uint8_t spare() const { return static_cast<std::uint8_t>(1 - r_.active); }
  bool in_trial() const { return r_.slots[spare()].state == SlotState::kTrial; }

  // What to run now: at the supervisor's start and whenever a program has
  // ended. Settles what a power loss interrupted; persist, then launch.
  Launch boot();
  Refusal begin_download();
  // A download's end: staged if the image was valid, else empty.
  Refusal end_download(Verdict v, std::uint32_t crc32, Version version);
  Refusal clear();
  // "Start program" (0x1F51 = 1): the staged program goes on trial.
  Refusal start_trial();
  Refusal confirm();
  Refusal trial_failed(RevertReason why);

 private:
  BootRecord r_;
};

// The record as stored: 36 bytes, "DBR1", the fields, a CRC-32. decode()
// refuses a wrong magic, CRC or value (the caller then keeps its backup).
inline constexpr std::uint32_t kRecordBytes = 36;
using RecordBytes = std::array<std::uint8_t, kRecordBytes>;
void encode(const BootRecord& r, RecordBytes& out);
bool decode(const RecordBytes& in, BootRecord& out);

const char* describe(RevertReason r);
const char* name(SlotState s);

}  // namespace fw::update
