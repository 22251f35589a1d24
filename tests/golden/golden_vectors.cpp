#include "golden_vectors.hpp"

#include <utility>

#include "delta/fixed/kinematics.hpp"
#include "delta/fixed/math.hpp"
#include "fw/collision.hpp"
#include "fw/deflection.hpp"
#include "fw/feed_forward.hpp"
#include "fw/joint_controller.hpp"
#include "fw/torque_from_current.hpp"
#include "fw/trajectory.hpp"
#include "fw/update/slots.hpp"

namespace fw::golden {

namespace {

using delta::fx::Q10_21;
using delta::fx::Q12_19;
using delta::fx::Q14_17;
using delta::fx::Q16_15;
using delta::fx::Q1_30;
using delta::fx::Q3_28;
using delta::fx::Q7_24;

// A line builder with integer formatting only.
class Line {
 public:
  explicit Line(TextSink& sink) : sink_(sink) {}
  Line& word(const char* w) {
    sep();
    while (*w && len_ + 1 < sizeof buf_) buf_[len_++] = *w++;
    return *this;
  }
  Line& num(std::int64_t v) {
    sep();
    char digits[24];
    int n = 0;
    const bool neg = v < 0;
    std::uint64_t u =
        neg ? static_cast<std::uint64_t>(-(v + 1)) + 1 : static_cast<std::uint64_t>(v);
    do {
      digits[n++] = static_cast<char>('0' + u % 10);
      u /= 10;
    } while (u != 0);
    if (neg && len_ + 1 < sizeof buf_) buf_[len_++] = '-';
    while (n > 0 && len_ + 1 < sizeof buf_) buf_[len_++] = digits[--n];
    return *this;
  }
  void end(std::uint32_t& lines) {
    buf_[len_++] = '\n';
    buf_[len_] = '\0';
    sink_.write(buf_);
    len_ = 0;
    ++lines;
  }

 private:
  void sep() {
    if (len_ > 0 && len_ + 1 < sizeof buf_) buf_[len_++] = ' ';
  }
  TextSink& sink_;
  char buf_[256]{};
  std::size_t len_{0};
};

// A fixed LCG for reproducible inputs (Numerical Recipes constants).
struct Lcg {
  std::uint32_t state;
  std::uint32_t next() { return state = state * 1664525u + 1013904223u; }
  // Uniform in [lo, hi), in 64-bit so that wide ranges cannot overflow.
  std::int32_t in(std::int32_t lo, std::int32_t hi) {
    const auto range = static_cast<std::uint32_t>(std::int64_t{hi} - lo);
    return static_cast<std::int32_t>(std::int64_t{lo} + next() % range);
  }
};

constexpr GeometryQ kGeometry{Q7_24::from(0.20), Q7_24::from(0.46), Q7_24::from(0.10),
                              Q7_24::from(0.035)};

TrajectoryConfig fourier_config() {
  TrajectoryConfig c;
  c.blend_ticks = 500;
  auto& f = c.fourier;
  f.base_frequency_mHz = 250;
  f.harmonics = 3;
  f.periods = 1;
  f.q0_rad = {Q3_28::from(0.45), Q3_28::from(0.40), Q3_28::from(0.50)};
  f.sin_amplitude_rad[0] = {Q3_28::from(0.10), Q3_28::from(-0.04), Q3_28::from(0.02)};
  f.cos_amplitude_rad[0] = {Q3_28::from(0.05), Q3_28::from(0.03), Q3_28::from(-0.01)};
  f.sin_amplitude_rad[1] = {Q3_28::from(-0.08), Q3_28::from(0.05), Q3_28::from(-0.01)};
  f.cos_amplitude_rad[1] = {Q3_28::from(0.06), Q3_28::from(0.02), Q3_28::from(0.02)};
  f.sin_amplitude_rad[2] = {Q3_28::from(0.07), Q3_28::from(0.03), Q3_28::from(0.015)};
  f.cos_amplitude_rad[2] = {Q3_28::from(-0.09), Q3_28::from(-0.03), Q3_28::from(0.01)};
  return c;
}

TrajectoryConfig pick_and_place_config() {
  TrajectoryConfig c;
  c.kind = TrajectoryKind::kPickAndPlace;
  auto& p = c.pick_and_place;
  p.waypoints = 3;
  p.points[0] = {Q7_24::from(-0.08), Q7_24::from(0.0), Q7_24::from(-0.48)};
  p.points[1] = {Q7_24::from(0.08), Q7_24::from(0.05), Q7_24::from(-0.42)};
  p.points[2] = {Q7_24::from(0.0), Q7_24::from(-0.08), Q7_24::from(-0.50)};
  p.segment_ticks = 400;
  p.cycles = 1;
  return c;
}

void reference_line(Line& l, const char* name, std::uint32_t tick, const JointReference& r,
                    std::uint32_t& lines) {
  l.word(name).num(tick);
  for (unsigned j = 0; j < 3; ++j)
    l.num(r.q_rad[j].raw()).num(r.qd_rad_s[j].raw()).num(r.qdd_rad_s2[j].raw());
  l.end(lines);
}

// The model with the drive train's torque gains and load friction along
// the pick-and-place reference: its torques divided as the fit's model
// solves them.
void drive_train_lines(Line& l, std::uint32_t& lines) {
  ModelParametersQ p = example_model_parameters();
  p.torque_gain_gap = {Q1_30::from(0.0), Q1_30::from(0.08), Q1_30::from(-0.06)};
  p.load_friction = {Q1_30::from(0.05), Q1_30::from(0.0), Q1_30::from(0.12)};
  const delta::fx::ModelQ m = delta::fx::prepare_model(kGeometry, p);
  const Trajectory pnp(kGeometry, pick_and_place_config());
  for (std::uint32_t tick = 7; tick <= pnp.length_ticks(); tick += 97) {
    JointReference r;
    pnp.reference(tick, r);
    Joint3Q12_19 tau{};
    const auto status = delta::fx::model_torque(m, r, tau);
    l.word("model-drive").num(tick).num(static_cast<int>(status));
    for (const Q12_19 t : tau) l.num(t.raw());
    l.end(lines);
  }
}

// Deflection compensation along the pick-and-place reference: the motors'
// reference past the arms' by c tau_ff, its velocity from the shift's
// change, at 500 Hz (every tick run, every 97th written).
void deflection_lines(Line& l, std::uint32_t& lines) {
  ModelParametersQ p = example_model_parameters();
  p.gearbox_compliance_rad_per_Nm = {Q1_30::from(1.0 / 3000), Q1_30::from(1.0 / 3400),
                                     Q1_30::from(1.0 / 2700)};
  const delta::fx::ModelQ m = delta::fx::prepare_model(kGeometry, p);
  const Trajectory pnp(kGeometry, pick_and_place_config());
  DeflectionCompensation compensation;
  for (std::uint32_t tick = 0; tick <= pnp.length_ticks(); ++tick) {
    JointReference r;
    pnp.reference(tick, r);
    Joint3Q12_19 tau{};
    delta::fx::model_torque(m, r, tau);
    JointReference motor = r;
    compensation.shift(p.gearbox_compliance_rad_per_Nm, tau, 500, true, motor);
    if (tick % 97 != 5) continue;
    l.word("deflection").num(tick);
    for (unsigned j = 0; j < 3; ++j) l.num(motor.q_rad[j].raw()).num(motor.qd_rad_s[j].raw());
    l.end(lines);
  }
}

// The identified model's arithmetic: exp and tanh, the model's torques
// along the pick-and-place reference with the states disturbed (with the
// platform's position and acceleration given, and without), and the
// trajectory check of its feed-forward against a max torque it breaks.
void model_lines(Line& l, Lcg& rng, std::uint32_t& lines) {
  for (int i = 0; i < 32; ++i) {
    const Q10_21 x = Q10_21::from_raw(rng.in(-40000000, 40000000) >> (i % 8));
    l.word("exp-tanh")
        .num(x.raw())
        .num(delta::fx::exp_neg(x).raw())
        .num(delta::fx::tanh(x).raw())
        .end(lines);
  }
  const delta::fx::ModelQ m = delta::fx::prepare_model(kGeometry, example_model_parameters());
  const Trajectory pnp(kGeometry, pick_and_place_config());
  for (std::uint32_t tick = 0; tick <= pnp.length_ticks(); tick += 41) {
    JointReference r;
    pnp.reference(tick, r);
    for (unsigned j = 0; j < 3; ++j) {
      r.qd_rad_s[j] = r.qd_rad_s[j] + Q10_21::from_raw(rng.in(-300000, 300000));
      r.qdd_rad_s2[j] = r.qdd_rad_s2[j] + Q14_17::from_raw(rng.in(-400000, 400000));
    }
    // Every other state as a joint-space one: the model solves the forward
    // kinematics and J qdd + J'q' itself.
    if ((tick / 41) % 2 == 1) r.platform_known = false;
    Joint3Q12_19 tau{};
    const auto status = delta::fx::model_torque(m, r, tau);
    l.word("model").num(tick).num(static_cast<int>(status));
    for (const Q12_19 t : tau) l.num(t.raw());
    l.end(lines);
  }
  drive_train_lines(l, lines);
  deflection_lines(l, lines);
  TrajectoryBounds bounds{
      kGeometry, JointLimits{}, {FeedForwardMode::kModel, {}, m}, Q12_19::from(1.3)};
  const TrajectoryCheck c = check_trajectory(bounds, pick_and_place_config());
  l.word("model-check").num(static_cast<int>(c.fault)).num(c.tick).num(c.joint).end(lines);
}

}  // namespace

// The firmware update's integer code: CRC-32 and SHA-256 of a fixed byte
// pattern in uneven pieces, a header's CRC, ImageCheck's verdicts, and the
// slot machine through a download, a trial, a power loss and a confirmation.
// The slot machine through a download, a trial, a power loss and a
// confirmation, and its record's CRC.
void slot_lines(Line& l, std::uint32_t& lines) {
  namespace u = delta::update;
  fw::update::BootRecord r;
  r.slots[0] = {fw::update::SlotState::kConfirmed, 0x11111111u, {1, 0, 0}};
  fw::update::Slots s(r);
  // Braced lists evaluate left to right: download, trial launched, a power
  // loss (the second boot reverts), then download, trial and confirm.
  const int steps[] = {static_cast<int>(s.begin_download()),
                       static_cast<int>(s.end_download(u::Verdict::kOk, 0x22222222u, {1, 1, 0})),
                       static_cast<int>(s.start_trial()),
                       s.boot().slot,
                       s.boot().slot,
                       static_cast<int>(s.record().last_revert),
                       static_cast<int>(s.confirm()),
                       static_cast<int>(s.begin_download()),
                       static_cast<int>(s.end_download(u::Verdict::kOk, 0x33333333u, {1, 2, 0})),
                       static_cast<int>(s.start_trial()),
                       s.boot().slot,
                       static_cast<int>(s.confirm()),
                       s.active()};
  l.word("slots");
  for (const int v : steps) l.num(v);
  l.end(lines);
  fw::update::RecordBytes rec;
  fw::update::encode(s.record(), rec);
  l.word("boot-record-crc")
      .num(rec[32] | (rec[33] << 8) | (rec[34] << 16) | (std::int64_t{rec[35]} << 24))
      .end(lines);
}

void update_lines(Line& l, std::uint32_t& lines) {
  namespace u = delta::update;
  std::uint8_t data[300];
  for (std::uint32_t i = 0; i < sizeof data; ++i)
    data[i] = static_cast<std::uint8_t>(i * 151u + 17u);
  for (const std::uint32_t n : {0u, 3u, 55u, 56u, 64u, 300u}) {
    u::Crc32 crc;
    u::Sha256 sha;
    for (std::uint32_t at = 0; at < n; at += 13) {
      const std::uint32_t piece = n - at < 13 ? n - at : 13;
      crc.add(std::span(data + at, piece));
      sha.add(std::span(data + at, piece));
    }
    const u::Sha256Digest d = sha.finish();
    l.word("crc32-sha256").num(n).num(crc.value());
    for (std::uint32_t i = 0; i < 32; i += 4) {
      l.num((std::int64_t{d[i]} << 24) | (d[i + 1] << 16) | (d[i + 2] << 8) | d[i + 3]);
    }
    l.end(lines);
  }
  u::ImageHeader h;
  h.identity = {0xDE17, 0x16, 0x00010002};
  h.version = {1, 2, 3};
  h.payload_bytes = 300;
  h.payload_crc32 = u::crc32(std::span(data, 300));
  h.payload_sha256 = u::sha256(std::span(data, 300));
  u::HeaderBytes raw;
  u::encode_header(h, raw);
  l.word("image-header-crc")
      .num(raw[252] | (raw[253] << 8) | (raw[254] << 16) | (std::int64_t{raw[255]} << 24))
      .end(lines);
  // The image as bytes, then one bit flipped at a time (none: 556).
  std::uint8_t image[256 + 300];
  for (std::uint32_t i = 0; i < 256; ++i) image[i] = raw[i];
  for (std::uint32_t i = 0; i < 300; ++i) image[256 + i] = data[i];
  for (const std::uint32_t flip : {556u, 0u, 8u, 40u, 100u, 555u}) {
    if (flip < sizeof image) image[flip] ^= 1;
    u::ImageCheck check(4096);
    if (check.add(std::span(image, 200))) (void)check.add(std::span(image + 200, 356));
    l.word("image-check").num(flip).num(static_cast<int>(check.finish())).end(lines);
    if (flip < sizeof image) image[flip] ^= 1;
  }
  slot_lines(l, lines);
}

namespace {

void math_lines(Line& l, Lcg& rng, std::uint32_t& lines) {
  for (int i = 0; i < 64; ++i) {
    const Q3_28 a = Q3_28::from_raw(static_cast<std::int32_t>(rng.next()));
    const auto sc = delta::fx::sincos(a);
    l.word("sincos").num(a.raw()).num(sc.sin.raw()).num(sc.cos.raw()).end(lines);
  }
  for (int i = 0; i < 64; ++i) {
    const std::int64_t y = rng.in(-2000000000, 2000000000) >> (i % 20);
    const std::int64_t x = rng.in(-2000000000, 2000000000) >> (i % 17);
    l.word("atan2").num(y).num(x).num(delta::fx::atan2_raw(y, x).raw()).end(lines);
  }
  for (int i = 0; i < 32; ++i) {
    const Q7_24 v = Q7_24::from_raw(rng.in(0, 2147483647));
    l.word("sqrt").num(v.raw()).num(delta::fx::sqrt<Q7_24>(v).raw()).end(lines);
  }
}

void kinematics_lines(Line& l, Lcg& rng, std::uint32_t& lines) {
  for (int i = 0; i < 96; ++i) {
    const delta::fx::Vec3Q p{Q7_24::from_raw(rng.in(-2500000, 2500000)),
                             Q7_24::from_raw(rng.in(-2500000, 2500000)),
                             Q7_24::from_raw(rng.in(-10000000, -4000000))};
    const auto ik = delta::fx::inverse_kinematics(kGeometry, p);
    l.word("ik")
        .num(p.x_m.raw())
        .num(p.y_m.raw())
        .num(p.z_m.raw())
        .num(static_cast<int>(ik.status));
    for (const Q3_28 t : ik.theta_rad) l.num(t.raw());
    l.end(lines);
    if (ik.status == delta::KinematicsStatus::kOk) {
      const auto fk = delta::fx::forward_kinematics(kGeometry, ik.theta_rad);
      l.word("fk")
          .num(static_cast<int>(fk.status))
          .num(fk.position.x_m.raw())
          .num(fk.position.y_m.raw())
          .num(fk.position.z_m.raw())
          .end(lines);
    }
  }
}

void trajectory_lines(Line& l, std::uint32_t& lines) {
  const Trajectory fourier(kGeometry, fourier_config());
  for (std::uint32_t tick = 0; tick <= fourier.length_ticks(); tick += 97) {
    JointReference r;
    fourier.reference(tick, r);
    reference_line(l, "fourier", tick, r, lines);
  }
  const TrajectoryCheck check = check_trajectory(kGeometry, fourier_config(), JointLimits{});
  l.word("check").num(static_cast<int>(check.fault)).num(check.tick).num(check.joint).end(lines);
  const Trajectory pnp(kGeometry, pick_and_place_config());
  for (std::uint32_t tick = 0; tick <= pnp.length_ticks(); tick += 61) {
    JointReference r;
    l.word("pnp-status").num(static_cast<int>(pnp.reference(tick, r))).end(lines);
    reference_line(l, "pnp", tick, r, lines);
  }
}

void torque_lines(Line& l, Lcg& rng, std::uint32_t& lines) {
  JointTorqueConfig tc;
  tc.gear_ratio = Q12_19::from(9.0);
  tc.torque_constant_Nm_per_A = Q7_24::from(0.08);
  tc.efficiency = Q1_30::from(0.95);
  tc.offset_Nm = Q12_19::from(-0.013);
  for (int i = 0; i < 32; ++i) {
    const Q12_19 amps = Q12_19::from_raw(rng.in(-6000000, 6000000));
    tc.inverted = (i % 3) == 0;
    l.word("torque")
        .num(amps.raw())
        .num(torque_from_current(tc, amps).raw())
        .num(current_from_torque(tc, torque_from_current(tc, amps)).raw())
        .end(lines);
  }
}

void control_lines(Line& l, Lcg& rng, std::uint32_t& lines) {
  const Trajectory fourier(kGeometry, fourier_config());
  JointGains gains;
  gains.ki_Nm_per_rad_s = Q16_15::from(20.0);
  const FeedForwardConfig nominal{
      FeedForwardMode::kNominal, NominalDynamics{Q12_19::from(0.0125), Q12_19::from(0.7026)}, {}};
  JointController ctl(gains, 1000);
  for (std::uint32_t tick = 0; tick < 200; tick += 7) {
    JointReference r;
    fourier.reference(tick + 600, r);
    JointAnglesQ q{};
    std::array<Q10_21, 3> qd{};
    for (unsigned j = 0; j < 3; ++j) {
      q[j] = r.q_rad[j] + Q3_28::from_raw(rng.in(-500000, 500000));
      qd[j] = r.qd_rad_s[j] + Q10_21::from_raw(rng.in(-200000, 200000));
    }
    std::array<bool, 3> sat{};
    Joint3Q12_19 ff{};
    feed_forward_torque(nominal, r, ff);
    const auto tau = ctl.update(r, q, qd, ff, sat);
    l.word("control").num(tick).num(tau[0].raw()).num(tau[1].raw()).num(tau[2].raw());
    l.num(sat[0]).num(sat[1]).num(sat[2]).end(lines);
  }
}

// The collision detector (fw/collision.hpp): residuals filtered tick by
// tick, thresholds at the reference's speed and acceleration, and which
// joint passes first; a contact's step on joint 3 from tick 40.
void collision_lines(Line& l, Lcg& rng, std::uint32_t& lines) {
  CollisionConfig c;
  c.detect = true;
  c.threshold_scale = Q12_19::from(1.5);
  for (unsigned j = 0; j < 3; ++j) {
    c.thresholds.base_Nm[j] =
        Q12_19::from(0.05) + Q12_19::from(0.01).scaled_by(static_cast<std::int32_t>(j));
    c.thresholds.per_speed_Nm_s_per_rad[j] = Q12_19::from(0.02);
    c.thresholds.per_acceleration_Nm_s2_per_rad[j] = Q12_19::from(0.001);
  }
  CollisionDetector d;
  for (std::uint32_t tick = 0; tick < 64; ++tick) {
    c.filter_shift = static_cast<std::uint8_t>(tick < 32 ? 2 : 3);
    std::array<Q12_19, 3> measured{}, model{};
    std::array<Q10_21, 3> qd{};
    std::array<Q14_17, 3> qdd{};
    for (unsigned j = 0; j < 3; ++j) {
      model[j] = Q12_19::from_raw(rng.in(-600000, 600000));
      measured[j] = model[j] + Q12_19::from_raw(rng.in(-20000, 20000));
      qd[j] = Q10_21::from_raw(rng.in(-4000000, 4000000));
      qdd[j] = Q14_17::from_raw(rng.in(-2000000, 2000000));
    }
    if (tick >= 40) measured[2] = measured[2] + Q12_19::from(0.4);
    CollisionEvent e;
    const bool hit = d.update(c, measured, model, qd, qdd, e);
    const auto& r = d.residual_Nm();
    l.word("collision").num(tick).num(r[0].raw()).num(r[1].raw()).num(r[2].raw());
    l.num(collision_threshold(c, 2, qd[2], qdd[2]).raw()).num(hit).num(hit ? e.joint : 9);
    l.end(lines);
  }
}

// The arithmetic itself on edge operands: saturating add, subtract and
// negation (one QADD or QSUB on Cortex-M4, a portable form on the host),
// and the rounding and saturation of mul (shifts of 30 and 31), narrow
// (8), div and convert at ties and at the extremes (SSAT on Cortex-M4).
constexpr std::int32_t kEdges[] = {0,          1,         -1,         3,
                                   -3,         1 << 29,   -(1 << 29), 123456789,
                                   -987654321, INT32_MAX, INT32_MIN,  INT32_MIN + 1};

void arithmetic_lines(Line& l, std::uint32_t& lines) {
  for (const std::int32_t a : kEdges) {
    l.word("convert")
        .num(a)
        .num(delta::fx::convert<Q7_24>(Q1_30::from_raw(a)).raw())
        .num(delta::fx::convert<Q1_30>(Q7_24::from_raw(a)).raw())
        .num((-Q7_24::from_raw(a)).raw())
        .end(lines);
    for (const std::int32_t b : kEdges) {
      const Q7_24 qa = Q7_24::from_raw(a), qb = Q7_24::from_raw(b);
      l.word("q")
          .num(a)
          .num(b)
          .num((qa + qb).raw())
          .num((qa - qb).raw())
          .num(delta::fx::mul<Q7_24>(Q1_30::from_raw(a), qb).raw())
          .num(delta::fx::mul<delta::fx::Q14_17>(qa, qb).raw())
          .num(delta::fx::narrow<8>(std::int64_t{a} * b))
          .num(delta::fx::div<Q7_24>(qa, qb).raw())
          .end(lines);
    }
  }
}

// The Cortex-M4's one-instruction primitives (QADD, QSUB, SSAT, SMULL,
// SMMLAR) against their portable forms (q.hpp) on extreme and random
// operands. Each line: the operands tried, the disagreements (0), and a
// checksum of the results, which the host (where both forms are the
// portable one) and the M4 must share.
struct Agreement {
  std::uint32_t operands = 0, mismatches = 0, checksum = 0;
  void add(std::int64_t fast, std::int64_t portable) {
    ++operands;
    if (fast != portable) ++mismatches;
    const auto u = static_cast<std::uint64_t>(fast);
    checksum =
        (checksum * 31u) ^ static_cast<std::uint32_t>(u) ^ static_cast<std::uint32_t>(u >> 32);
  }
  void line(Line& l, const char* name, std::uint32_t& lines) const {
    l.word("asm-vs-portable").word(name).num(operands).num(mismatches).num(checksum).end(lines);
  }
};

// A 32-bit operand of random size and sign.
std::int32_t random_narrow(Lcg& rng) {
  return static_cast<std::int32_t>(rng.next()) >> (rng.next() % 32);
}
// A 64-bit value of random size and sign below 2^62 in magnitude (what a
// product of two 32-bit values reaches).
std::int64_t random_wide(Lcg& rng) {
  const std::uint64_t bits = (std::uint64_t{rng.next()} << 32) | rng.next();
  const auto v = static_cast<std::int64_t>(bits >> (2 + rng.next() % 62));
  return (rng.next() & 1u) != 0 ? -v : v;
}

constexpr int kRandomOperands = 20000;

template <int Shift>
void narrow_agreement(Agreement& a, Lcg& rng) {
  const std::int64_t half = std::int64_t{1} << (Shift - 1);
  // Where the rounded value leaves 32 bits, on both sides, and around 0.
  for (const std::int64_t at : {std::int64_t{INT32_MAX} * (2 * half),
                                std::int64_t{INT32_MIN} * (2 * half), std::int64_t{0}}) {
    for (const std::int64_t d : {-half - 1, -half, -half + 1, std::int64_t{-1}, std::int64_t{0},
                                 std::int64_t{1}, half - 1, half, half + 1}) {
      a.add(delta::fx::narrow<Shift>(at + d), delta::fx::portable::narrow<Shift>(at + d));
    }
  }
  for (int i = 0; i < kRandomOperands / 8; ++i) {
    const std::int64_t v = random_wide(rng);
    a.add(delta::fx::narrow<Shift>(v), delta::fx::portable::narrow<Shift>(v));
  }
}

template <int... S>
void every_narrow(Agreement& a, Lcg& rng, std::integer_sequence<int, S...>) {
  (narrow_agreement<S + 1>(a, rng), ...);
}

void primitive_lines(Line& l, std::uint32_t& lines) {
  namespace fx = delta::fx;
  Lcg rng{20261204u};
  Agreement add, sub, wide, high, narrow;
  const auto pair = [&](std::int32_t x, std::int32_t y) {
    add.add(fx::add_saturate(x, y), fx::portable::add_saturate(x, y));
    sub.add(fx::sub_saturate(x, y), fx::portable::sub_saturate(x, y));
    wide.add(fx::wide_product(x, y), fx::portable::wide_product(x, y));
  };
  for (const std::int32_t x : kEdges) {
    for (const std::int32_t y : kEdges) {
      pair(x, y);
      for (const std::int32_t c : kEdges) {
        high.add(fx::add_high_product(c, x, y), fx::portable::add_high_product(c, x, y));
      }
    }
  }
  for (int i = 0; i < kRandomOperands; ++i) {
    const std::int32_t x = random_narrow(rng), y = random_narrow(rng), c = random_narrow(rng);
    pair(x, y);
    high.add(fx::add_high_product(c, x, y), fx::portable::add_high_product(c, x, y));
  }
  every_narrow(narrow, rng, std::make_integer_sequence<int, 31>{});
  add.line(l, "qadd", lines);
  sub.line(l, "qsub", lines);
  wide.line(l, "smull", lines);
  high.line(l, "smmlar", lines);
  narrow.line(l, "ssat-narrow-1-to-31", lines);
}

}  // namespace

std::uint32_t write_golden_vectors(TextSink& out) {
  std::uint32_t lines = 0;
  Line l(out);
  l.word("delta-golden/1").end(lines);
  Lcg rng{12345u};
  math_lines(l, rng, lines);
  kinematics_lines(l, rng, lines);
  trajectory_lines(l, lines);
  torque_lines(l, rng, lines);
  control_lines(l, rng, lines);
  arithmetic_lines(l, lines);
  model_lines(l, rng, lines);
  update_lines(l, lines);
  primitive_lines(l, lines);
  Lcg collision_rng{777u};
  collision_lines(l, collision_rng, lines);
  l.word("end").num(lines + 1).end(lines);
  return lines;
}

ModelParametersQ example_model_parameters() {
  ModelParametersQ m;
  m.kind = delta::fx::ModelKind::kDelta;
  m.arm_inertia_kg_m2 = {Q7_24::from(7.2e-3), Q7_24::from(7.5e-3), Q7_24::from(6.9e-3)};
  m.arm_gravity_cos_Nm = {Q12_19::from(0.441), Q12_19::from(0.452), Q12_19::from(0.430)};
  m.arm_gravity_sin_Nm = {Q12_19::from(0.031), Q12_19::from(-0.02), Q12_19::from(0.012)};
  m.platform_inertial_mass_kg = Q7_24::from(0.42);
  m.platform_weight_mass_kg = Q7_24::from(0.40);
  m.forearm_coupling_kg = Q7_24::from(0.05);
  m.viscous_friction_Nm_s_per_rad = {Q12_19::from(0.02), Q12_19::from(0.025), Q12_19::from(0.018)};
  m.coulomb_friction_Nm = {Q12_19::from(0.06), Q12_19::from(0.05), Q12_19::from(0.07)};
  m.stribeck_friction_Nm = {Q12_19::from(0.03), Q12_19::from(0.02), Q12_19::from(0.025)};
  m.stribeck_velocity_rad_s = Q10_21::from(0.1);
  m.torque_offset_Nm = {Q12_19::from(0.01), Q12_19::from(-0.02), Q12_19::from(0.005)};
  return m;
}

}  // namespace fw::golden
