# hil/rig.sh: sourced by hil/identify-demo and tests/bench/hil_lockstep_speed.sh.
# Starts the emulator and a lock-step delta_fw with Modbus TCP on loopback
# on a vcan interface, and stops them again.
#
#   rig_start BIN IFACE LOGDIR [EMULATOR OPTIONS...]
#                                sets rig_modbus (HOST:PORT); logs in LOGDIR,
#                                and the model loaded over the bus in
#                                LOGDIR/delta_fw_model.bin (feed_forward.store)
#   rig_stop                     TERM to the firmware, then the emulator
# The caller sets `trap rig_stop EXIT` and `set -euo pipefail`.

rig_emu_pid=""
rig_fw_pid=""
rig_drain_pid=""
rig_modbus=""

rig_stop() {
  # The firmware first (it disables the drives and writes its closing line,
  # which the drain copies to fw.log before it sees the end), then the emulator.
  local p
  for p in "$rig_fw_pid" "$rig_drain_pid" "$rig_emu_pid"; do
    [ -n "$p" ] || continue
    [ "$p" = "$rig_drain_pid" ] || kill -TERM "$p" 2>/dev/null || true
    wait "$p" 2>/dev/null || true
  done
  rig_emu_pid="" rig_fw_pid="" rig_drain_pid=""
}

# Waits for a line containing $2 on the already-open descriptor $1.
rig_await_line() {
  local line
  while IFS= read -r -t 60 line <&"$1"; do
    [[ "$line" == *"$2"* ]] && return 0
  done
  echo "rig: did not see '$2'" >&2
  return 1
}

rig_start() {
  local bin=$1 iface=$2 logs=$3 line p
  shift 3
  for p in delta_drive_emu delta_fw host_id; do
    [ -x "$bin/$p" ] || { echo "rig: $bin/$p is missing; build first (README)" >&2; return 2; }
  done
  mkdir -p "$logs"
  # The programs' lines come through pipes (process substitution).
  exec 4< <(exec "$bin/delta_drive_emu" --can "$iface" "$@" 2> "$logs/emulator.log")
  rig_emu_pid=$!
  rig_await_line 4 "ready on $iface"

  exec 5< <(exec "$bin/delta_fw" --can "$iface" --lockstep --set modbus.tcp=127.0.0.1:0 \
    --set "feed_forward.store=$logs/delta_fw_model.bin" 2>&1)
  rig_fw_pid=$!
  rig_modbus=""
  : > "$logs/fw.log"
  while IFS= read -r -t 60 line <&5; do
    echo "$line" >> "$logs/fw.log"
    [[ "$line" == *"Modbus TCP on "* ]] && rig_modbus=${line##*Modbus TCP on }
    [[ "$line" == "delta_fw: ready" ]] && break
  done
  if [ -z "$rig_modbus" ]; then
    cat "$logs/fw.log" >&2
    echo "rig: delta_fw did not come up" >&2
    return 1
  fi
  # Keep draining the firmware's messages into its log.
  cat <&5 >> "$logs/fw.log" &
  rig_drain_pid=$!
}
