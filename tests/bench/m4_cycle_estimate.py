#!/usr/bin/env python3
"""Cycles per control step on a Cortex-M4, estimated from the executed
instructions: qemu runs the step image one instruction per translation block
and logs every one it executes (-singlestep -d exec,nochain); each executed
instruction of a measured window (between the image's step_window_begin and
step_window_end around the control steps: a pick-and-place trajectory,
then a Fourier excitation) is priced with the cycle counts of the
Cortex-M4 Technical Reference Manual (ARM 100166, table 3-1, zero wait
states), branches as taken or not from the next executed address.

The pipeline refill P of a taken branch is 1 to 3 cycles. Three figures:
best (P = 1, neighbouring loads and stores pipelined as the TRM allows),
middle (P = 2, pipelined) and worst (P = 3, every load and store 2 cycles);
divides count their worst case, 12, in all three. The worst figure is an
upper bound for code fetched without wait states (SRAM, or flash through a
warm cache).

  tests/bench/m4_cycle_estimate.py [BUILD_DIR]
"""
import re
import subprocess
import sys
from collections import Counter

build = sys.argv[1] if len(sys.argv) > 1 else "build"
elf = f"{build}/firmware-target/step_target.elf"
STEPS = 200  # the image's run_control_steps count
MHZ = 168

# Disassembly: address -> (size in bytes, mnemonic, operands).
insns = {}
dump = subprocess.run(["arm-none-eabi-objdump", "-d", elf], capture_output=True, text=True,
                      check=True).stdout
line_re = re.compile(r"^\s+([0-9a-f]+):\s+([0-9a-f]{4})(?: ([0-9a-f]{4}))?\s+(\S+)\s*(.*)$")
for line in dump.splitlines():
    m = line_re.match(line)
    if m:
        size = 4 if m.group(3) else 2
        insns[int(m.group(1), 16)] = (size, m.group(4), m.group(5))


def base(mnemonic):
    # Drop the width qualifier and a condition or flag-setting suffix.
    m = mnemonic.split(".")[0]
    return m


BRANCHES = {"b", "bl", "blx", "bx", "cbz", "cbnz", "tbb", "tbh"}
CONDS = ("eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt",
         "gt", "le", "al")


def kind(mnemonic, operands):
    """A class for the cycle table."""
    m = base(mnemonic)
    if m in BRANCHES or (m.startswith("b") and m[1:] in CONDS):
        return "branch"
    if m in ("udiv", "sdiv"):
        return "divide"
    if m in ("ldrd", "strd"):
        return "double"
    if m.startswith("ldm") or m.startswith("stm") or m in ("push", "pop"):
        return "multiple"
    if m.startswith("ldr") or m.startswith("str"):
        return "single"
    if m == "mov" and operands.startswith("pc"):
        return "branch"
    return "alu"  # data processing, multiplies (MUL..SMLAL are 1 cycle on the M4), IT


def registers_in_list(operands):
    inside = operands[operands.find("{") + 1:operands.find("}")]
    n = 0
    for part in inside.split(","):
        part = part.strip()
        if "-" in part:
            lo, hi = part.split("-")
            n += int(hi.strip()[1:]) - int(lo.strip()[1:]) + 1
        elif part:
            n += 1
    return n


def load_store_parts(mnemonic, operands):
    """(is load, destination or source register, base register, register offset)."""
    regs = operands.split(",")
    first = regs[0].strip()
    inside = operands[operands.find("[") + 1:operands.find("]")] if "[" in operands else ""
    parts = [x.strip() for x in inside.split(",")] if inside else []
    base_reg = parts[0] if parts else ""
    reg_offset = len(parts) > 1 and parts[1].startswith("r")
    return base(mnemonic).startswith("ldr"), first, base_reg, reg_offset


def cycles(pc, next_pc, refill, previous_pc=None, pipelined=False):
    size, mnemonic, operands = insns[pc]
    k = kind(mnemonic, operands)
    taken = next_pc is not None and next_pc != pc + size
    if k == "branch":
        extra = 1 if base(mnemonic) in ("tbb", "tbh") else 0
        return 1 + extra + (refill if taken else 0)
    if k == "divide":
        return 12
    if k == "double":
        return 3
    if k == "multiple":
        n = registers_in_list(operands)
        return 1 + n + (refill if "pc" in operands else 0)
    if k == "single":
        if operands.startswith("pc"):
            return 2 + refill
        if pipelined and previous_pc is not None:
            _, pm, po = insns[previous_pc]
            if kind(pm, po) == "single":
                prev_load, prev_reg, _, prev_reg_offset = load_store_parts(pm, po)
                load, _, base_reg, _ = load_store_parts(mnemonic, operands)
                # TRM 3.3.2: neighbouring single loads and stores pipeline
                # their address and data phases (one cycle), except after a
                # store, or when the address needs the previous load's result.
                if prev_load and base_reg != prev_reg:
                    return 1
                if not prev_load and load and not prev_reg_offset:
                    return 1
        return 2
    return 1


# The measured windows: after step_window_begin returns into the steps,
# until step_window_end; in the order the image runs them.
WINDOWS = ["pick-and-place", "Fourier excitation"]
qemu = subprocess.Popen(
    ["qemu-system-arm", "-M", "mps2-an386", "-nographic", "-icount", "shift=0", "-singlestep",
     "-d", "exec,nochain", "-D", "/dev/stderr", "-semihosting-config",
     "enable=on,target=native", "-kernel", elf],
    stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
traces = []
state = "before"
for line in qemu.stderr:
    if not line.startswith("Trace"):
        continue
    fields = line.split()
    if "ff038201" in fields[3]:
        continue  # the same instruction again, re-executed for its I/O access
    symbol = fields[-1]
    if state == "before":
        if symbol.endswith("step_window_beginEv"):
            state = "begin"
        continue
    if state == "begin":
        if symbol.endswith("step_window_beginEv"):
            continue
        state = "in"
        traces.append([])
    if symbol.endswith("step_window_endEv"):
        state = "before"
        if len(traces) == len(WINDOWS):
            break
        continue
    traces[-1].append(int(fields[3].split("/")[1], 16))
qemu.kill()
qemu.wait()
if len(traces) != len(WINDOWS):
    sys.exit(f"m4_cycle_estimate: {len(traces)} measured windows in the trace, not {len(WINDOWS)}")

names = {(1, True): "best (P = 1, loads pipelined)",
         (2, True): "middle (P = 2, loads pipelined)",
         (3, False): "worst (P = 3, every load 2 cycles)"}
for window, trace in zip(WINDOWS, traces):
    # Each executed instruction with its neighbours: the price depends on
    # nothing else, and a step repeats few of them.
    triples = Counter(zip([None] + trace[:-1], trace, trace[1:] + [None]))
    by_kind = Counter()
    # (refill P, loads and stores pipelined as the TRM allows)
    models = {(1, True): 0, (2, True): 0, (3, False): 0}
    for (prev, pc, nxt), count in triples.items():
        if pc not in insns:
            sys.exit(f"m4_cycle_estimate: executed address {pc:#x} is not in the disassembly")
        by_kind[kind(insns[pc][1], insns[pc][2])] += count
        for p, pipelined in models:
            models[(p, pipelined)] += count * cycles(pc, nxt, p, prev, pipelined)
    n = len(trace) / STEPS
    print(f"{window}: cortex-m4 cycle estimate: {n:.0f} instructions per control step "
          f"({len(trace)} over {STEPS} steps)")
    for k, c in sorted(by_kind.items(), key=lambda kv: -kv[1]):
        print(f"  {k:9s} {c / STEPS:7.1f} per step")
    for key, total in models.items():
        c = total / STEPS
        print(f"  {names[key]:35s} {c:5.0f} cycles = {c / MHZ:4.1f} us at {MHZ} MHz "
              f"(CPI {c / n:.2f})")
