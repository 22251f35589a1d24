#!/usr/bin/env bash
# Lock-step HIL speed: the wall time of a 20 s excitation at the default
# 500 Hz, inside the vcan runner. The emulator and delta_fw (lock-step,
# Modbus on loopback) as in README command 1, and host_id excite running
# path1 with 4 Fourier periods (20 s of excitation, 24.4 s of bus time with
# the approach, the blends and the hold) while it records the CAN log.
#
#   hil/vcan-run -- tests/bench/hil_lockstep_speed.sh [--bin DIR] [--runs N]
#                                                     [--plant mujoco|lumped]
#
# Prints, per run, the wall time against the bus time and their ratio, and
# delta_fw's own count; the target is at most 2x real time. Then the CPU
# time each program took over all runs (where the wall time goes). --plant
# is the emulator's (default mujoco, as in README command 1).
set -euo pipefail

bin=build/bin
runs=3
iface=${DELTA_VCAN:-vcan0}
plant=mujoco
while [ $# -gt 0 ]; do
  case "$1" in
    --bin) bin=${2:?}; shift 2 ;;
    --runs) runs=${2:?}; shift 2 ;;
    --can) iface=${2:?}; shift 2 ;;
    --plant) plant=${2:?}; shift 2 ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    *) echo "hil_lockstep_speed: unknown option '$1'" >&2; exit 2 ;;
  esac
done
here=$(cd "$(dirname "$0")/../.." && pwd)
# shellcheck source=hil/rig.sh
. "$here/hil/rig.sh"
trap rig_stop EXIT
out=$(mktemp -d)
rig_start "$bin" "$iface" "$out" --plant "$plant"
echo "hil_lockstep_speed: the emulator's plant: $plant"

# CPU seconds (user + system) a running process has taken so far.
cpu_s() {
  awk -v hz="$(getconf CLK_TCK)" '{ print ($14 + $15) / hz }' "/proc/$1/stat"
}

rate_hz=500
emu_cpu0=$(cpu_s "$rig_emu_pid")
fw_cpu0=$(cpu_s "$rig_fw_pid")
excite_cpu=0
bus_total=0
TIMEFORMAT='%U %S'
for ((k = 1; k <= runs; k++)); do
  start=$(date +%s.%N)
  if ! { time "$bin/host_id" excite --modbus "$rig_modbus" --trajectory path1 --repetitions 4 \
      --can "$iface" -o "$out/run$k.csv" > "$out/excite$k.log" 2>&1; } 2> "$out/excite_cpu$k"; then
    cat "$out/excite$k.log" "$out/fw.log" >&2
    echo "hil_lockstep_speed: run $k failed (logs above)" >&2
    exit 1
  fi
  end=$(date +%s.%N)
  sent=$(sed -n 's/.* recorded of \([0-9]*\) sent.*/\1/p' "$out/excite$k.log")
  [ -n "$sent" ] || { cat "$out/excite$k.log" >&2; echo "hil_lockstep_speed: no count" >&2; exit 1; }
  awk -v s="$start" -v e="$end" -v n="$sent" -v r="$rate_hz" -v k="$k" 'BEGIN {
    wall = e - s; bus = n / r;
    printf "run %d: %d cycles, %.1f s of bus time in %.1f s wall: %.2f x real time\n", k, n, bus, wall, wall / bus }'
  excite_cpu=$(awk -v a="$excite_cpu" '{ print a + $1 + $2 }' "$out/excite_cpu$k")
  bus_total=$(awk -v a="$bus_total" -v n="$sent" -v r="$rate_hz" 'BEGIN { print a + n / r }')
done
awk -v emu="$(awk -v a="$emu_cpu0" -v b="$(cpu_s "$rig_emu_pid")" 'BEGIN { print b - a }')" \
    -v fw="$(awk -v a="$fw_cpu0" -v b="$(cpu_s "$rig_fw_pid")" 'BEGIN { print b - a }')" \
    -v ex="$excite_cpu" -v bus="$bus_total" 'BEGIN {
  printf "cpu over the runs, per second of bus time: delta_drive_emu %.2f s, delta_fw %.2f s, host_id excite %.2f s\n",
    emu / bus, fw / bus, ex / bus }'
rig_stop
grep -m1 "cycles in" "$out/fw.log" | sed 's/^/firmware, whole session: /'
rm -rf "$out"
