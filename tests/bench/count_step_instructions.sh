#!/usr/bin/env bash
# Instructions per firmware control step (each path of
# tests/bench/step/step_bench.hpp: a pick-and-place trajectory with IK and a
# Fourier excitation, each with the nominal and with the identified model's
# feed-forward; joint control, torque from current, through
# Controller::step()):
#   - host build: valgrind's callgrind over exactly the measured loop;
#   - Cortex-M4 image: qemu mps2-an386 with -icount shift=0, SysTick
#     calibrated on a loop of known length (firmware/target/step_target_main.cpp).
# Run after building the release or ci preset: tests/bench/count_step_instructions.sh [build]
set -euo pipefail
build=${1:-build}
steps=1000
out=$(mktemp)
trap 'rm -f "$out"' EXIT
for kind in pick_and_place_nominal pick_and_place_model fourier_nominal fourier_model; do
  valgrind --tool=callgrind --callgrind-out-file="$out" \
    --toggle-collect='*measured_control_steps*' "$build/bin/step_host" "$steps" "$kind" >/dev/null 2>&1
  host_total=$(callgrind_annotate "$out" 2>/dev/null | awk '/PROGRAM TOTALS/ {gsub(",", "", $1); print $1}')
  echo "host (x86-64, -O3), $kind: $((host_total / steps)) instructions per control step (callgrind, $steps steps)"
done
qemu-system-arm -M mps2-an386 -nographic -icount shift=0 -semihosting-config enable=on,target=native \
  -kernel "$build/firmware-target/step_target.elf" 2>&1 | sed 's/^/cortex-m4 (qemu): /'
