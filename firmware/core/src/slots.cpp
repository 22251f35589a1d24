#include "fw/update/slots.hpp"

#include "delta/little_endian.hpp"

namespace fw::update {

Launch Slots::boot() {
  Slot& spare_slot = r_.slots[spare()];
  if (spare_slot.state == SlotState::kReceiving) spare_slot.state = SlotState::kEmpty;
  if (spare_slot.state == SlotState::kTrial) {
    if (r_.trial_started) {
      (void)trial_failed(RevertReason::kPowerLost);
    } else {
      r_.trial_started = true;
      return {spare(), true};
    }
  }
  return {r_.active, false};
}

Refusal Slots::begin_download() {
  if (in_trial()) return Refusal::kTrialUnderWay;
  r_.slots[spare()] = Slot{SlotState::kReceiving, 0, {}};
  return Refusal::kNone;
}

Refusal Slots::end_download(Verdict v, std::uint32_t crc32, Version version) {
  Slot& s = r_.slots[spare()];
  if (s.state != SlotState::kReceiving) return Refusal::kNotReceiving;
  r_.last_verdict = v;
  s = v == Verdict::kOk ? Slot{SlotState::kStaged, crc32, version} : Slot{};
  return Refusal::kNone;
}

Refusal Slots::clear() {
  if (in_trial()) return Refusal::kTrialUnderWay;
  r_.slots[spare()] = Slot{};
  return Refusal::kNone;
}

Refusal Slots::start_trial() {
  if (in_trial()) return Refusal::kTrialUnderWay;
  Slot& s = r_.slots[spare()];
  if (s.state != SlotState::kStaged) return Refusal::kNothingStaged;
  s.state = SlotState::kTrial;
  r_.trial_started = false;
  r_.last_revert = RevertReason::kNone;
  return Refusal::kNone;
}

Refusal Slots::confirm() {
  if (!in_trial() || !r_.trial_started) return Refusal::kNoTrial;
  r_.slots[spare()].state = SlotState::kConfirmed;
  r_.active = spare();
  r_.trial_started = false;
  return Refusal::kNone;
}

Refusal Slots::trial_failed(RevertReason why) {
  if (!in_trial()) return Refusal::kNoTrial;
  r_.slots[spare()].state = SlotState::kReverted;
  r_.trial_started = false;
  r_.last_revert = why;
  return Refusal::kNone;
}

namespace {

constexpr std::uint8_t kMagic[4] = {'D', 'B', 'R', '1'};

// Bytes 8-19 slot 0, 20-31 slot 1: state, zero, major, minor, patch, CRC-32.
constexpr std::uint32_t slot_offset(unsigned i) {
  return 8 + 12 * i;
}

}  // namespace

void encode(const BootRecord& r, RecordBytes& out) {
  out = RecordBytes{};
  for (std::uint32_t i = 0; i < 4; ++i) out[i] = kMagic[i];
  out[4] = r.active;
  out[5] = r.trial_started ? 1 : 0;
  out[6] = static_cast<std::uint8_t>(r.last_revert);
  out[7] = static_cast<std::uint8_t>(r.last_verdict);
  for (unsigned i = 0; i < 2; ++i) {
    const std::uint32_t at = slot_offset(i);
    out[at] = static_cast<std::uint8_t>(r.slots[i].state);
    delta::put_le16(out, at + 2, r.slots[i].version.major);
    delta::put_le16(out, at + 4, r.slots[i].version.minor);
    delta::put_le16(out, at + 6, r.slots[i].version.patch);
    delta::put_le32(out, at + 8, r.slots[i].crc32);
  }
  delta::put_le32(out, 32, delta::update::crc32(std::span(out.data(), 32)));
}

bool decode(const RecordBytes& in, BootRecord& out) {
  for (std::uint32_t i = 0; i < 4; ++i) {
    if (in[i] != kMagic[i]) return false;
  }
  if (delta::get_le32(in, 32) != delta::update::crc32(std::span(in.data(), 32))) return false;
  if (in[4] > 1 || in[5] > 1 || in[6] >= kRevertReasonCount ||
      in[7] >= delta::update::kVerdictCount) {
    return false;
  }
  BootRecord r;
  r.active = in[4];
  r.trial_started = in[5] == 1;
  r.last_revert = static_cast<RevertReason>(in[6]);
  r.last_verdict = static_cast<Verdict>(in[7]);
  for (unsigned i = 0; i < 2; ++i) {
    const std::uint32_t at = slot_offset(i);
    if (in[at] >= kSlotStateCount || in[at + 1] != 0) return false;
    r.slots[i].state = static_cast<SlotState>(in[at]);
    r.slots[i].version = {delta::get_le16(in, at + 2), delta::get_le16(in, at + 4),
                          delta::get_le16(in, at + 6)};
    r.slots[i].crc32 = delta::get_le32(in, at + 8);
  }
  out = r;
  return true;
}

const char* describe(RevertReason r) {
  switch (r) {
    case RevertReason::kNone:
      return "none";
    case RevertReason::kNoConfirmation:
      return "the new program did not confirm in time";
    case RevertReason::kExited:
      return "the new program exited before it confirmed";
    case RevertReason::kCrashed:
      return "the new program crashed before it confirmed";
    case RevertReason::kPowerLost:
      return "the controller restarted during the trial";
    case RevertReason::kNotStartable:
      return "the new program could not be started";
  }
  return "unknown";
}

const char* name(SlotState s) {
  switch (s) {
    case SlotState::kEmpty:
      return "empty";
    case SlotState::kReceiving:
      return "receiving";
    case SlotState::kStaged:
      return "staged";
    case SlotState::kTrial:
      return "trial";
    case SlotState::kConfirmed:
      return "confirmed";
    case SlotState::kReverted:
      return "reverted";
  }
  return "unknown";
}

}  // namespace fw::update
