#!/usr/bin/env python3
"""Cycles of every control step on a Cortex-M4, priced from the executed
instructions, and the step's budget checked against them.

qemu runs the budget image (firmware/target/step_budget_main.cpp) and logs
each block of instructions it translates (-d in_asm) and each block it
executes (-d exec,nochain). For each path of tests/bench/step/step_bench.hpp
(pick-and-place and Fourier excitation, with the nominal and with the
identified model's feed-forward), the image runs 200 control steps between
step_window_begin and step_window_end and calls step_done after each, so
every step is priced on its own. Each executed instruction gets its cycle
count from the Cortex-M4 Technical Reference Manual (ARM 100166, table 3-1,
zero wait states), a branch as taken or not from the next executed address.

The pipeline refill P of a taken branch is 1 to 3 cycles. Three models:
best (P = 1, neighbouring loads and stores pipelined as the TRM allows),
middle (P = 2, pipelined) and worst (P = 3, every load and store 2 cycles);
divides count their worst case, 12, in all three. The worst model is an
upper bound for code fetched without wait states (SRAM, or flash through a
warm cache).

  tests/bench/m4_cycle_estimate.py [BUILD_DIR] [--budget-us US] [--mhz MHZ]

With --budget-us it exits 1 unless every step of every path costs at most
US microseconds at MHZ (default 168) in the worst model.
"""
import argparse
import os
import re
import subprocess
import sys
from collections import Counter

BRANCHES = {"b", "bl", "blx", "bx", "cbz", "cbnz", "tbb", "tbh"}
CONDS = ("eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt",
         "gt", "le", "al")
# (refill P, loads and stores pipelined as the TRM allows)
MODELS = {"best": (1, True), "middle": (2, True), "worst": (3, False)}
MODEL_TEXT = {"best": "best (P = 1, loads pipelined)",
              "middle": "middle (P = 2, loads pipelined)",
              "worst": "worst (P = 3, every load 2 cycles)"}


def disassemble(elf):
    """address -> (size in bytes, mnemonic, operands)."""
    insns = {}
    dump = subprocess.run(["arm-none-eabi-objdump", "-d", elf], capture_output=True, text=True,
                          check=True).stdout
    line_re = re.compile(r"^\s+([0-9a-f]+):\s+([0-9a-f]{4})(?: ([0-9a-f]{4}))?\s+(\S+)\s*(.*)$")
    for line in dump.splitlines():
        m = line_re.match(line)
        if m:
            size = 4 if m.group(3) else 2
            insns[int(m.group(1), 16)] = (size, m.group(4), m.group(5))
    return insns


def base(mnemonic):
    # Drop the width qualifier.
    return mnemonic.split(".")[0]


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


class Pricer:
    def __init__(self, insns):
        self.insns = insns
        self.cache = {}

    def cycles(self, pc, next_pc, refill, previous_pc, pipelined):
        size, mnemonic, operands = self.insns[pc]
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
            return 1 + registers_in_list(operands) + (refill if "pc" in operands else 0)
        if k == "single":
            if operands.startswith("pc"):
                return 2 + refill
            if pipelined and previous_pc is not None:
                _, pm, po = self.insns[previous_pc]
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

    def block(self, previous_pc, pcs, next_pc):
        """(instructions, {model: cycles}, Counter of kinds) of one executed block,
        entered after previous_pc and left for next_pc."""
        key = (previous_pc, pcs[0], len(pcs), next_pc)
        if key not in self.cache:
            totals = {name: 0 for name in MODELS}
            kinds = Counter()
            for i, pc in enumerate(pcs):
                if pc not in self.insns:
                    sys.exit(f"m4_cycle_estimate: executed address {pc:#x} is not in the disassembly")
                prev = pcs[i - 1] if i > 0 else previous_pc
                nxt = pcs[i + 1] if i + 1 < len(pcs) else next_pc
                kinds[kind(self.insns[pc][1], self.insns[pc][2])] += 1
                for name, (refill, pipelined) in MODELS.items():
                    totals[name] += self.cycles(pc, nxt, refill, prev, pipelined)
            self.cache[key] = (len(pcs), totals, kinds)
        return self.cache[key]


def trace_steps(elf):
    """The executed blocks of each measured step, per window: a list of windows,
    each a list of steps, each a list of blocks (lists of addresses); and the
    path names the image printed."""
    # The trace through a pipe of its own; the image's semihosting output
    # (the path names) on stderr.
    trace_read, trace_write = os.pipe()
    qemu = subprocess.Popen(
        ["qemu-system-arm", "-M", "mps2-an386", "-nographic", "-d", "in_asm,exec,nochain",
         "-D", f"/dev/fd/{trace_write}", "-semihosting-config", "enable=on,target=native",
         "-kernel", elf],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, pass_fds=(trace_write,))
    os.close(trace_write)
    blocks = {}  # start address -> the block's addresses, as translated
    translating = None
    windows, step = [], None
    state = "before"
    for line in os.fdopen(trace_read, "r"):
        if line.startswith("IN:"):
            translating = []
            continue
        if translating is not None:
            if line.startswith("0x"):
                translating.append(int(line[:line.index(":")], 16))
                continue
            if translating:
                blocks[translating[0]] = translating
            translating = None
        if not line.startswith("Trace"):
            continue
        symbol = line.rsplit(None, 1)[-1]
        start = int(line[line.index("[") + 1:].split("/")[1], 16)
        if symbol.endswith("step_window_beginEv"):
            state, step = "in", []
            windows.append([])
        elif symbol.endswith("step_window_endEv"):
            state, step = "before", None  # the loop's exit after the last step_done
        elif symbol.endswith("step_doneEv"):
            if step:
                windows[-1].append(step)
            step = []
        elif state == "in":
            step.append(blocks[start])
    _, err = qemu.communicate()
    out = err.decode(errors="replace")
    if qemu.returncode != 0:
        sys.exit(f"m4_cycle_estimate: the budget image exited with {qemu.returncode} "
                 "(a path did not run all its steps)")
    return windows, [l.strip() for l in out.splitlines() if l.strip()]


def price_steps(pricer, steps):
    """Per step: (instructions, {model: cycles}); and the kinds over all steps."""
    priced, kinds = [], Counter()
    for blocks in steps:
        n, totals = 0, {name: 0 for name in MODELS}
        for i, pcs in enumerate(blocks):
            previous_pc = blocks[i - 1][-1] if i > 0 else None
            next_pc = blocks[i + 1][0] if i + 1 < len(blocks) else None
            bn, bt, bk = pricer.block(previous_pc, pcs, next_pc)
            n += bn
            kinds.update(bk)
            for name in MODELS:
                totals[name] += bt[name]
        priced.append((n, totals))
    return priced, kinds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("build", nargs="?", default="build")
    parser.add_argument("--budget-us", type=float, help="fail if a step takes longer (worst model)")
    parser.add_argument("--mhz", type=float, default=168.0)
    args = parser.parse_args()
    elf = f"{args.build}/firmware-target/step_budget.elf"
    pricer = Pricer(disassemble(elf))
    windows, names = trace_steps(elf)
    if len(windows) != len(names) or not windows:
        sys.exit(f"m4_cycle_estimate: {len(windows)} measured windows in the trace, "
                 f"{len(names)} paths named by the image")
    over = []
    for name, steps in zip(names, windows):
        priced, kinds = price_steps(pricer, steps)
        count = len(priced)
        mean_n = sum(n for n, _ in priced) / count
        print(f"{name}: {count} steps, {mean_n:.0f} instructions per step")
        for k, c in sorted(kinds.items(), key=lambda kv: -kv[1]):
            print(f"  {k:9s} {c / count:7.1f} per step")
        for model in MODELS:
            cycles = [t[model] for _, t in priced]
            mean, worst = sum(cycles) / count, max(cycles)
            print(f"  {MODEL_TEXT[model]:35s} mean {mean:5.0f} cycles = {mean / args.mhz:4.1f} us, "
                  f"slowest step {worst:5d} = {worst / args.mhz:4.1f} us at {args.mhz:g} MHz")
        slowest = max(t["worst"] for _, t in priced)
        if args.budget_us is not None and slowest > args.budget_us * args.mhz:
            over.append(f"{name}: {slowest} cycles = {slowest / args.mhz:.1f} us")
    if args.budget_us is not None:
        ceiling = args.budget_us * args.mhz
        if over:
            print(f"OVER BUDGET ({args.budget_us:g} us = {ceiling:.0f} cycles at {args.mhz:g} MHz, "
                  f"worst model): " + "; ".join(over))
            return 1
        print(f"within budget: every step of every path at most {args.budget_us:g} us "
              f"({ceiling:.0f} cycles at {args.mhz:g} MHz) in the worst model")
    return 0


if __name__ == "__main__":
    sys.exit(main())
