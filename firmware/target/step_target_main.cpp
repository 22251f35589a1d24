// The Cortex-M image that counts instructions per control step on qemu run
// with -icount shift=0 (one instruction = 1 ns of virtual time): SysTick,
// clocked by the CPU clock, is calibrated on a loop of known length, then
// read around 200 control steps of each path (step_bench.hpp).
#include <cstdint>

#include "delta/fixed/dynamics.hpp"
#include "delta/fixed/kinematics.hpp"
#include "delta/fixed/math.hpp"
#include "semihosting.hpp"
#include "step_bench.hpp"

extern "C" int firmware_main();

namespace {

volatile std::uint32_t& reg(std::uint32_t address) {
  return *reinterpret_cast<volatile std::uint32_t*>(address);
}
constexpr std::uint32_t kSysTickCtrl = 0xE000E010u, kSysTickLoad = 0xE000E014u,
                        kSysTickVal = 0xE000E018u;

std::uint32_t begin_ticks = 0, end_ticks = 0;

void restart() {
  reg(kSysTickCtrl) = 0;
  reg(kSysTickLoad) = 0x00FFFFFFu;
  reg(kSysTickVal) = 0;
  reg(kSysTickCtrl) = 0x5u;  // enable, CPU clock, no interrupt
}
void mark_begin() {
  restart();  // writing VAL clears it; the counter then reloads from LOAD
  begin_ticks = 0x00FFFFFFu;
}
void mark_end() {
  end_ticks = reg(kSysTickVal);
}
void step_window_begin() {
  mark_begin();
}
void step_window_end() {
  mark_end();
}

void print_number(const char* label, std::uint32_t v) {
  char buf[48];
  int n = 0;
  for (const char* p = label; *p;) buf[n++] = *p++;
  char digits[12];
  int d = 0;
  do {
    digits[d++] = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v != 0);
  while (d > 0) buf[n++] = digits[--d];
  buf[n++] = '\n';
  buf[n] = '\0';
  semihosting::write(buf);
}

// Instructions per control step of each path; false if one did not run
// all its steps.
bool count_steps(std::uint32_t calib_ticks) {
  const std::uint32_t steps = 200;
  bool all_done = true;
  for (const auto& path : fw::bench::kStepPaths) {
    const std::uint32_t done =
        fw::bench::run_control_steps(path, steps, {step_window_begin, step_window_end, nullptr});
    const std::uint32_t step_ticks = begin_ticks - end_ticks;
    // instructions = ticks * (2,000,000 / calib_ticks)
    const auto per_step = static_cast<std::uint32_t>(
        (std::uint64_t{step_ticks} * 2000000u / calib_ticks) / (done ? done : 1));
    semihosting::write(path.name);
    print_number(" steps ", done);
    semihosting::write(path.name);
    print_number(" instructions_per_step ", per_step);
    all_done = all_done && done == steps;
  }
  return all_done;
}

// The instructions of 1000 calls of body, divided by 1000.
template <class Body>
void per_call(std::uint32_t calib_ticks, const char* label, Body&& body) {
  mark_begin();
  for (std::uint32_t i = 0; i < 1000; ++i) body(i);
  mark_end();
  print_number(label,
               static_cast<std::uint32_t>(
                   (std::uint64_t{begin_ticks - end_ticks} * 2000000u / calib_ticks) / 1000));
}

volatile std::int32_t sink = 0;

// The primitives, 1000 calls each, for where the step's instructions go.
void count_primitives(std::uint32_t calib_ticks) {
  per_call(calib_ticks, "instructions_per_atan2 ", [](std::uint32_t i) {
    sink = delta::fx::atan2_raw(std::int64_t{123456789} + i * 7919,
                                std::int64_t{987654321} - i * 104729)
               .raw();
  });
  per_call(calib_ticks, "instructions_per_isqrt ", [](std::uint32_t i) {
    sink = static_cast<std::int32_t>(
        delta::fx::isqrt_round((std::uint64_t{1} << 60) + i * 1234567891u));
  });
  per_call(calib_ticks, "instructions_per_sincos ", [](std::uint32_t i) {
    sink = delta::fx::sincos(delta::fx::Q3_28::from_raw(static_cast<std::int32_t>(i * 2654435u)))
               .cos.raw();
  });
  static constexpr delta::fx::GeometryQ g{delta::fx::Q7_24::from(0.2), delta::fx::Q7_24::from(0.46),
                                          delta::fx::Q7_24::from(0.1),
                                          delta::fx::Q7_24::from(0.035)};
  per_call(calib_ticks, "instructions_per_ik ", [](std::uint32_t i) {
    const delta::fx::Vec3Q p{delta::fx::Q7_24::from_raw(static_cast<std::int32_t>(i * 1000)),
                             delta::fx::Q7_24::from(0.01), delta::fx::Q7_24::from(-0.45)};
    sink = delta::fx::inverse_kinematics(g, p).theta_rad[0].raw();
  });
  per_call(calib_ticks, "instructions_per_model ", [](std::uint32_t i) {
    delta::fx::ModelParametersQ m;
    m.kind = delta::fx::ModelKind::kDelta;
    m.platform_inertial_mass_kg = delta::fx::Q7_24::from(0.4);
    m.stribeck_velocity_rad_s = delta::fx::Q10_21::from(0.1);
    delta::fx::JointStateQ s;
    s.q_rad = {delta::fx::Q3_28::from_raw(static_cast<std::int32_t>(i * 100000)),
               delta::fx::Q3_28::from(0.5), delta::fx::Q3_28::from(0.4)};
    s.qd_rad_s = {delta::fx::Q10_21::from(1.0), delta::fx::Q10_21::from(-2.0),
                  delta::fx::Q10_21::from(0.5)};
    s.qdd_rad_s2 = {delta::fx::Q14_17::from(10.0), delta::fx::Q14_17::from(-20.0),
                    delta::fx::Q14_17::from(5.0)};
    delta::fx::Joint3Q12_19 tau{};
    delta::fx::model_torque(delta::fx::prepare_model(g, m), s, tau);
    sink = tau[0].raw();
  });
}

}  // namespace

extern "C" int firmware_main() {
  // Calibration: 2 instructions per iteration (subs, bne) x 1,000,000.
  mark_begin();
  std::uint32_t count = 1000000;
  asm volatile("1: subs %0, %0, #1\n bne 1b" : "+r"(count) : : "cc");
  mark_end();
  const std::uint32_t calib_ticks = begin_ticks - end_ticks;
  print_number("calibration_ticks_per_2e6_instructions ", calib_ticks);
  const bool all_done = count_steps(calib_ticks);
  count_primitives(calib_ticks);
  return all_done ? 0 : 1;
}
