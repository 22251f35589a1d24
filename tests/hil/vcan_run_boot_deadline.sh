#!/usr/bin/env bash
# hil/vcan-run's boot watchdog: a VM that does not reach the command within
# --boot-timeout is stopped and booted once more, the command is never run,
# and vcan-run exits 125 naming the deadline and each boot. A deadline of
# 1 s is far below any boot here (5 to 30 s), so both boots are stopped.
# Then a normal deadline lets the same command run once.
#   vcan_run_boot_deadline.sh VCAN_RUN
set -uo pipefail
vcan_run=${1:?usage: vcan_run_boot_deadline.sh VCAN_RUN}
scratch=$(mktemp -d "${TMPDIR:-/tmp}/delta_boot_deadline.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
fail() { echo "FAIL: $*"; echo "--- stderr:"; cat "$scratch/stderr"; exit 1; }

"$vcan_run" --vm --boot-timeout 1 -- touch "$scratch/ran" 2> "$scratch/stderr"
rc=$?
[ "$rc" -eq 125 ] || fail "exit $rc with a 1 s boot deadline, expected 125"
[ ! -e "$scratch/ran" ] || fail "the command ran although no boot reached it"
for line in "the VM did not reach the command within 1 s (boot 1 of 2)" \
            "booting the VM again" \
            "the VM did not reach the command within 1 s (boot 2 of 2)"; do
  grep -qF "vcan-run: $line" "$scratch/stderr" || fail "stderr lacks '$line'"
done
[ "$(grep -c 'booting the VM again' "$scratch/stderr")" -eq 1 ] || fail "more than one retry"
echo "ok: a 1 s boot deadline stops both boots, exit 125, the command never ran"

"$vcan_run" --vm --boot-timeout 120 -- touch "$scratch/ran" 2> "$scratch/stderr"
rc=$?
[ "$rc" -eq 0 ] || fail "exit $rc with a 120 s boot deadline"
[ -e "$scratch/ran" ] || fail "the command did not run"
! grep -q "did not reach" "$scratch/stderr" || fail "a boot was stopped"
echo "ok: with a 120 s deadline the VM boots once and the command runs"
