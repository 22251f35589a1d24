#!/usr/bin/env bash
# Lock-step soak (#19): at least --minutes of bus time of excitation on vcan
# with the multibody plant, the rig of README command 1 (emulator, lock-step
# delta_fw with Modbus on loopback) and host_id excite recording path1 runs
# of 100 Fourier periods (504.4 s of bus time each) back to back. Passes
# when every run finished with nothing lost and nothing stale, and the
# resident memory of delta_fw and of the emulator stayed flat: at the end at
# most --rss-growth-kb above their first sample once the first run was
# under way (the recorder keeps its log in memory by design, so it is not
# watched).
#
#   hil/vcan-run --timeout 3600 -- tests/bench/hil_soak.sh [--bin DIR]
#       [--minutes M] [--plant mujoco|lumped] [--rss-growth-kb K]
#       [--repetitions N]   (path1's Fourier periods per run, default 100)
#
# Prints each run's summary, the memory samples' first, largest and last
# values, and "soak: PASS" or "soak: FAIL: why" (exit 1).
set -euo pipefail

bin=build/bin
minutes=10
iface=${DELTA_VCAN:-vcan0}
plant=mujoco
growth_kb=1024
repetitions=100
while [ $# -gt 0 ]; do
  case "$1" in
    --bin) bin=${2:?}; shift 2 ;;
    --minutes) minutes=${2:?}; shift 2 ;;
    --can) iface=${2:?}; shift 2 ;;
    --plant) plant=${2:?}; shift 2 ;;
    --rss-growth-kb) growth_kb=${2:?}; shift 2 ;;
    --repetitions) repetitions=${2:?}; shift 2 ;;
    -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
    *) echo "hil_soak: unknown option '$1'" >&2; exit 2 ;;
  esac
done
here=$(cd "$(dirname "$0")/../.." && pwd)
# shellcheck source=hil/rig.sh
. "$here/hil/rig.sh"
out=$(mktemp -d)
sampler_pid=""
cleanup() {
  [ -z "$sampler_pid" ] || kill "$sampler_pid" 2>/dev/null || true
  rig_stop
}
trap cleanup EXIT
rig_start "$bin" "$iface" "$out" --plant "$plant"

rss_kb() { awk '/^VmRSS:/ {print $2}' "/proc/$1/status" 2>/dev/null || echo 0; }
# One line every 10 s: seconds since the start, delta_fw's RSS, the emulator's.
(
  t0=$(date +%s)
  while kill -0 "$rig_fw_pid" 2>/dev/null; do
    echo "$(($(date +%s) - t0)) $(rss_kb "$rig_fw_pid") $(rss_kb "$rig_emu_pid")"
    sleep 10  # the sampling period, not a wait for anything
  done
) > "$out/rss.txt" &
sampler_pid=$!

rate_hz=500
bus_s=0
runs=0
fail=""
start=$(date +%s)
while awk -v b="$bus_s" -v m="$minutes" 'BEGIN { exit !(b < m * 60) }'; do
  runs=$((runs + 1))
  if ! "$bin/host_id" excite --modbus "$rig_modbus" --trajectory path1 --repetitions "$repetitions" \
      --can "$iface" -o "$out/run$runs.csv" > "$out/excite$runs.log" 2>&1; then
    fail="run $runs did not finish: $(tail -n 3 "$out/excite$runs.log" | tr '\n' ' ')"
    break
  fi
  line=$(grep -m1 " recorded of " "$out/excite$runs.log")
  echo "run $runs: ${line#"${line%%[! ]*}"}"
  sent=$(sed -n 's/.* recorded of \([0-9]*\) sent.*/\1/p' <<< "$line")
  if [[ "$line" != *"sent, 0 lost, 0 stale left out"* ]]; then
    fail="run $runs lost or left out samples"
    break
  fi
  bus_s=$(awk -v b="$bus_s" -v n="$sent" -v r="$rate_hz" 'BEGIN { print b + n / r }')
  rm -f "$out/run$runs.csv"
done
wall_s=$(($(date +%s) - start))
kill "$sampler_pid" 2>/dev/null || true
wait "$sampler_pid" 2>/dev/null || true
sampler_pid=""
echo "soak: $runs run(s), $bus_s s of bus time in $wall_s s wall ($plant plant)"
# Memory: the first sample taken 30 s or more after the start (the first
# run under way), the largest, the last.
fw_first="" emu_first="" fw_max="" emu_max="" fw_last="" emu_last=""
read -r fw_first emu_first < <(awk '$1 >= 30 { print $2, $3; exit }' "$out/rss.txt") || true
read -r fw_max emu_max < <(awk '$2 > f { f = $2 } $3 > e { e = $3 } END { print f, e }' \
  "$out/rss.txt") || true
read -r fw_last emu_last < <(tail -n 1 "$out/rss.txt" | awk '{ print $2, $3 }') || true
samples=$(wc -l < "$out/rss.txt")
echo "soak: RSS kB in $samples samples (first after 30 s / largest / last):" \
  "delta_fw $fw_first / $fw_max / $fw_last, emulator $emu_first / $emu_max / $emu_last"
if [ -z "$fail" ]; then
  [ -n "$fw_first" ] || fail="no memory sample after 30 s"
fi
if [ -z "$fail" ] && [ $((fw_last - fw_first)) -gt "$growth_kb" ]; then
  fail="delta_fw's memory grew by $((fw_last - fw_first)) kB"
fi
if [ -z "$fail" ] && [ $((emu_last - emu_first)) -gt "$growth_kb" ]; then
  fail="the emulator's memory grew by $((emu_last - emu_first)) kB"
fi
if [ -n "$fail" ]; then
  echo "soak: FAIL: $fail" >&2
  cat "$out/fw.log" >&2
  exit 1
fi
echo "soak: PASS"
rm -rf "$out"
