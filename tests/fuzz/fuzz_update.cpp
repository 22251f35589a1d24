// libFuzzer harness: the flash image check and the A/B slot logic
// (docs/flashing.md). Bit 0 of the first byte picks the part.
//
// Image (bit 0 clear): the rest is an image, fed to ImageCheck once whole
// and once in the pieces the input's first bytes choose. The verdict and
// header_valid() must not depend on the pieces; an accepted image must
// decode, have exactly the header's payload length and its CRC-32. With
// bit 1 set the harness builds a well-formed image around the rest (header
// fields from the input, the payload's length, CRC-32 and SHA-256
// computed), spoiling one of them when bits 2-4 say so: the check must
// accept the good one and name the spoiled part.
//
// Slots (bit 0 set): a boot record from 36 bytes (or a fresh one), then one
// event per byte (boot, download begin/end, clear, start, confirm, fail,
// power loss). After each: the record round-trips through its 36 bytes, a
// refused event changes nothing, the active slot changes only by a
// confirmed trial, and boot() runs the active slot or a trial's first start.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <vector>

#include "delta/update/crc32.hpp"
#include "delta/update/image.hpp"
#include "delta/update/sha256.hpp"
#include "fw/update/slots.hpp"

namespace {

namespace up = delta::update;
namespace fu = fw::update;

void require(bool ok) {
  if (!ok) std::abort();
}

constexpr std::uint32_t kCapacity = 4096;

// The check's verdict with the image cut into pieces of the given sizes
// (cycled; 0 becomes 1), then finished.
struct Checked {
  up::Verdict verdict;
  bool header_valid;
};
Checked check_in_pieces(std::span<const std::uint8_t> image, std::span<const std::uint8_t> sizes) {
  up::ImageCheck check(kCapacity);
  std::size_t at = 0;
  for (std::size_t k = 0; at < image.size(); ++k) {
    std::size_t n = sizes.empty() ? image.size() : sizes[k % sizes.size()] + 1u;
    if (n > image.size() - at) n = image.size() - at;
    check.add(image.subspan(at, n));
    at += n;
  }
  const up::Verdict v = check.finish();
  return {v, check.header_valid()};
}

void check_image(std::span<const std::uint8_t> image, std::span<const std::uint8_t> sizes) {
  const Checked whole = check_in_pieces(image, {});
  const Checked pieces = check_in_pieces(image, sizes);
  require(whole.verdict == pieces.verdict);
  require(whole.header_valid == pieces.header_valid);
  if (whole.verdict != up::Verdict::kOk) return;
  require(image.size() >= up::kHeaderBytes);
  up::HeaderBytes raw{};
  std::memcpy(raw.data(), image.data(), raw.size());
  up::ImageHeader h;
  require(up::decode_header(raw, h) == up::Verdict::kOk);
  const auto payload = image.subspan(up::kHeaderBytes);
  require(h.payload_bytes == payload.size());
  require(up::crc32(payload) == h.payload_crc32);
}

// What bits 2-4 spoil in a built image, and the verdict that must follow.
enum class Spoil : std::uint8_t { kNone, kLength, kCrc, kSha, kMagic, kHeaderCrc, kTruncate };

up::Verdict expected_verdict(Spoil s) {
  switch (s) {
    case Spoil::kNone:
      return up::Verdict::kOk;
    case Spoil::kLength:
    case Spoil::kTruncate:
      return up::Verdict::kLengthMismatch;
    case Spoil::kCrc:
      return up::Verdict::kPayloadCrc;
    case Spoil::kSha:
      return up::Verdict::kPayloadSha256;
    case Spoil::kMagic:
      return up::Verdict::kNotAnImage;
    case Spoil::kHeaderCrc:
      return up::Verdict::kHeaderCrc;
  }
  return up::Verdict::kOk;
}

void build_and_check(std::uint8_t mode, std::span<const std::uint8_t> rest) {
  if (rest.size() < 12) return;
  up::ImageHeader h;
  h.identity = {rest[0], rest[1], rest[2]};
  h.version = {rest[3], rest[4], rest[5]};
  std::memcpy(h.build_id.data(), rest.data() + 6, 6);
  const auto sizes = rest.subspan(6, 6);
  const auto payload = rest.subspan(12);
  h.payload_bytes = static_cast<std::uint32_t>(payload.size());
  h.payload_crc32 = up::crc32(payload);
  h.payload_sha256 = up::sha256(payload);
  const auto spoil = static_cast<Spoil>((mode >> 2) % 7);
  if (spoil == Spoil::kLength) h.payload_bytes += 1;
  if (spoil == Spoil::kCrc) h.payload_crc32 ^= 1u;
  if (spoil == Spoil::kSha) h.payload_sha256[31] ^= 1u;
  up::HeaderBytes raw{};
  up::encode_header(h, raw);
  if (spoil == Spoil::kMagic) raw[0] ^= 0x20;
  if (spoil == Spoil::kHeaderCrc) raw[40] ^= 0x01;  // inside the build id
  std::vector<std::uint8_t> image(raw.begin(), raw.end());
  image.insert(image.end(), payload.begin(), payload.end());
  if (spoil == Spoil::kTruncate) {
    if (payload.empty()) return;
    image.pop_back();
  }
  up::ImageCheck check(kCapacity);
  check.add(image);
  const up::Verdict v = check.finish();
  if (spoil == Spoil::kMagic || spoil == Spoil::kHeaderCrc) {
    require(v == expected_verdict(spoil));  // the header is refused before its fields count
  } else if (h.payload_bytes > kCapacity) {
    require(v == up::Verdict::kTooLarge);
  } else {
    require(v == expected_verdict(spoil));
  }
  check_image(image, sizes);
}

bool same(const fu::BootRecord& a, const fu::BootRecord& b) {
  fu::RecordBytes x{};
  fu::RecordBytes y{};
  fu::encode(a, x);
  fu::encode(b, y);
  return x == y;
}

// What an event did: refused (kNone: taken), or booted, and how.
struct EventOutcome {
  fu::Refusal refused{fu::Refusal::kNone};
  bool booted{false};
  fu::Launch launch{};
};

// Event `event % 8` on the slots, with its argument.
EventOutcome do_event(fu::Slots& slots, std::uint8_t event, std::uint8_t arg) {
  EventOutcome o;
  switch (event % 8) {
    case 0:
      o.launch = slots.boot();
      o.booted = true;
      break;
    case 1:
      o.refused = slots.begin_download();
      break;
    case 2:
      o.refused = slots.end_download(static_cast<up::Verdict>(arg % up::kVerdictCount), arg * 7919u,
                                     {arg, 0, 1});
      break;
    case 3:
      o.refused = slots.clear();
      break;
    case 4:
      o.refused = slots.start_trial();
      break;
    case 5:
      o.refused = slots.confirm();
      break;
    case 6:
      o.refused = slots.trial_failed(static_cast<fu::RevertReason>(1 + arg % 5));
      break;
    case 7: {  // power loss: what was stored comes back, then the boot
      fu::RecordBytes stored{};
      fu::encode(slots.record(), stored);
      fu::BootRecord back;
      require(fu::decode(stored, back));
      slots = fu::Slots(back);
      o.launch = slots.boot();
      o.booted = true;
      break;
    }
  }
  return o;
}

// The slots' invariants after an event: the record round-trips, a refusal
// changed nothing, only a confirmation changes the active slot (to a
// confirmed one), and a boot launches the spare only for a trial.
void require_invariants(const fu::BootRecord& before, const fu::Slots& slots, bool confirmed,
                        const EventOutcome& o) {
  const fu::BootRecord& after = slots.record();
  fu::RecordBytes bytes{};
  fu::encode(after, bytes);
  fu::BootRecord round;
  require(fu::decode(bytes, round) && same(round, after));
  if (o.refused != fu::Refusal::kNone) require(same(before, after));
  if (confirmed) {
    require(after.active != before.active);
    require(after.slots[after.active].state == fu::SlotState::kConfirmed);
  } else {
    require(after.active == before.active);
    const fu::Slot& a = before.slots[before.active];
    const fu::Slot& b = after.slots[after.active];
    require(a.state == b.state && a.crc32 == b.crc32 && a.version.major == b.version.major);
  }
  if (o.booted) {
    const bool trial_start = o.launch.trial;
    require(o.launch.slot == (trial_start ? slots.spare() : slots.active()));
    if (trial_start) require(slots.in_trial() && after.trial_started);
  }
}

// One event; the slots' invariants after it.
void apply_event(fu::Slots& slots, std::uint8_t event, std::uint8_t arg) {
  const fu::BootRecord before = slots.record();
  const EventOutcome o = do_event(slots, event, arg);
  const bool confirmed = event % 8 == 5 && o.refused == fu::Refusal::kNone;
  require_invariants(before, slots, confirmed, o);
}

void run_slots(std::span<const std::uint8_t> rest) {
  fu::BootRecord start;
  start.slots[0].state = fu::SlotState::kConfirmed;
  if (rest.size() >= fu::kRecordBytes) {
    fu::RecordBytes bytes{};
    std::memcpy(bytes.data(), rest.data(), bytes.size());
    fu::BootRecord decoded;
    if (fu::decode(bytes, decoded)) {
      fu::RecordBytes again{};
      fu::encode(decoded, again);
      require(again == bytes);  // one encoding per record
      start = decoded;
    }
    rest = rest.subspan(fu::kRecordBytes);
  }
  fu::Slots slots(start);
  for (std::size_t i = 0; i + 1 < rest.size(); i += 2) apply_event(slots, rest[i], rest[i + 1]);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t mode = data[0];
  const std::span<const std::uint8_t> rest(data + 1, size - 1);
  if ((mode & 1) != 0) {
    run_slots(rest);
  } else if ((mode & 2) != 0) {
    build_and_check(mode, rest);
  } else {
    const std::size_t n = rest.size() < 4 ? rest.size() : 4;
    check_image(rest.subspan(n), rest.first(n));
  }
  return 0;
}
