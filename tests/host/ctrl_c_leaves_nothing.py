#!/usr/bin/env python3
"""Ctrl-C (SIGINT) and SIGTERM to host_id simulate, predict and fit, as
processes: while they compute, and while they write their outputs (the
moment a temporary file appears beside them). Each must end by the signal
and leave no temporary and no part: none of its outputs, or (a signal that
came while the finished files were being put in place) all of them.
Usage: ctrl_c_leaves_nothing.py HOST_ID"""
import os
import signal
import subprocess
import sys
import tempfile
import time

host_id = sys.argv[1]


def fail(what):
    sys.exit("FAIL: " + what)


def interrupted(cmd, outputs, out_dir, sig, while_writing):
    """Runs cmd, signals it (at once, or when a temporary appears in out_dir)
    and checks what it leaves."""
    before = set(os.listdir(out_dir))
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    if while_writing:
        deadline = time.monotonic() + 120
        while not any(".tmp." in f for f in os.listdir(out_dir)):
            if p.poll() is not None:
                break  # a short write can end before the folder is looked at again
            if time.monotonic() > deadline:
                p.kill()
                fail(f"{' '.join(cmd)}: no temporary file within 120 s")
            time.sleep(0.002)  # polling the folder, not waiting for a moment
    if p.poll() is None:
        p.send_signal(sig)
    p.wait(timeout=120)
    if p.returncode not in (-sig, 0):
        fail(f"{' '.join(cmd)}: ended with {p.returncode}: {p.stderr.read().decode()}")
    if any(".tmp." in f for f in os.listdir(out_dir)):
        fail(f"{' '.join(cmd)}: left a temporary: {sorted(os.listdir(out_dir))}")
    left = set(os.listdir(out_dir)) - before
    if left and left != set(outputs):
        fail(f"{' '.join(cmd)} {'while writing' if while_writing else 'at once'}, signal {sig}: "
             f"left {sorted(left)}")
    for f in left:
        os.remove(os.path.join(out_dir, f))
    return bool(left)


with tempfile.TemporaryDirectory() as d:
    inputs = os.path.join(d, "in")
    os.mkdir(inputs)
    log = os.path.join(inputs, "log.csv")
    result = os.path.join(inputs, "result.json")
    subprocess.run([host_id, "simulate", "--duration", "600", "-o", log, "--quiet"], check=True,
                   stdout=subprocess.DEVNULL)
    subprocess.run([host_id, "fit", log, "--method", "ls", "--quiet", "--out", result], check=True,
                   stdout=subprocess.DEVNULL)
    out = os.path.join(d, "out")
    os.mkdir(out)
    commands = {
        "simulate": ([host_id, "simulate", "--duration", "600", "-o", os.path.join(out, "s.csv")],
                     ["s.csv"]),
        "predict": ([host_id, "predict", result, log, "-o", os.path.join(out, "p.csv")], ["p.csv"]),
        "fit": ([host_id, "fit", log, "--method", "ls", "--out", os.path.join(out, "r.json"),
                 "--plot", os.path.join(out, "r.svg")], ["r.json", "r.svg"]),
    }
    whole = 0
    for name, (cmd, outputs) in commands.items():
        for sig in (signal.SIGINT, signal.SIGTERM):
            for while_writing in (False, True):
                whole += interrupted(cmd, outputs, out, sig, while_writing)
print(f"simulate, predict and fit, interrupted by SIGINT and SIGTERM 12 times while computing "
      f"and while writing: no temporary and no part left; {whole} of them had put every output "
      f"in place whole already")
