#!/usr/bin/env python3
"""The speed and memory bars of `host_id fit`, measured as ratios in one run.

  tests/bench/fit_speed.py [--build build] [--runs 7] [--compare OTHER_HOST_ID]

Makes the 60 s and 10-minute, 1 kHz logs of docs/dev/performance.md (1.5 %
torque noise, 17-bit encoders) with `host_id simulate` unless they exist,
then times, each in a fresh process and taking the median of --runs:
  - reading and parsing the 60 s log (build/bin/read_log_once),
  - `host_id fit LOG --method ls` and `host_id fit LOG` (default PSO),
and measures the peak memory (maximum resident set) of `host_id fit
--method ls` on the 10-minute log (bar: 4x the file), and of `simulate` and
`predict` writing a 10-minute log (bar: 1.5x their output). It prints the
ratios the bars are stated in. With --compare, another host_id (an older build) is timed in the same
run, interleaved, so that both see the same machine.
"""
import argparse
import os
import statistics
import subprocess
import sys
import time

LOG_DIR = "/tmp/delta_fit_speed"


def make_log(host_id, seconds):
    path = os.path.join(LOG_DIR, f"log{seconds}.csv")
    if not os.path.exists(path):
        os.makedirs(LOG_DIR, exist_ok=True)
        subprocess.run([host_id, "simulate", "-o", path, "--duration", str(seconds),
                        "--torque-noise", "0.015", "--encoder-bits", "17"],
                       check=True, stdout=subprocess.DEVNULL)
    return path


def wall(cmd):
    """Wall seconds of cmd in a fresh process."""
    t0 = time.perf_counter()
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        sys.exit(f"fit_speed: {' '.join(cmd)} failed: {done.stderr.decode()}")
    return seconds


def peak_bytes(cmd):
    """The maximum resident set of cmd alone, through /usr/bin/time."""
    done = subprocess.run(["/usr/bin/time", "-f", "%M"] + cmd, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, check=True)
    return int(done.stderr.decode().strip().splitlines()[-1]) * 1024


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--compare", help="another host_id to time in the same run")
    a = ap.parse_args()
    host_id = os.path.join(a.build, "bin", "host_id")
    reader = os.path.join(a.build, "bin", "read_log_once")
    log60 = make_log(host_id, 60)
    log600 = make_log(host_id, 600)
    size60 = os.path.getsize(log60)
    size600 = os.path.getsize(log600)

    programs = {"this": host_id}
    if a.compare:
        programs["compare"] = a.compare
    cases = {"read+parse": [reader, log60]}
    for name, prog in programs.items():
        cases[f"{name}: fit --method ls"] = [prog, "fit", log60, "--method", "ls", "--quiet"]
        cases[f"{name}: fit (pso)"] = [prog, "fit", log60, "--quiet"]
    times = {k: [] for k in cases}
    for _ in range(a.runs):  # interleaved, so that all see the same load
        for k, cmd in cases.items():
            times[k].append(wall(cmd))
    med = {k: statistics.median(v) for k, v in times.items()}
    rp = med["read+parse"]
    print(f"60 s log: {size60 / 1e6:.1f} MB; median of {a.runs} fresh processes")
    print(f"  read+parse           {rp * 1e3:8.1f} ms  {size60 / rp / 1e6:6.0f} MB/s")
    for k in cases:
        if k == "read+parse":
            continue
        print(f"  {k:28s} {med[k] * 1e3:8.1f} ms  {med[k] / rp:5.2f} x read+parse")
    print(f"10-minute log: {size600 / 1e6:.1f} MB")
    result = os.path.join(LOG_DIR, "result60.json")
    subprocess.run([host_id, "fit", log60, "--method", "ls", "--quiet", "--out", result],
                   check=True, stdout=subprocess.DEVNULL)
    written = os.path.join(LOG_DIR, "written.csv")
    for name, prog in programs.items():
        peak = peak_bytes([prog, "fit", log600, "--method", "ls", "--quiet"])
        print(f"  {name}: fit --method ls peak memory {peak / 2**20:7.1f} MiB"
              f"  {peak / size600:5.2f} x the file")
        peak = peak_bytes([prog, "simulate", "--duration", "600", "--quiet", "-o", written])
        print(f"  {name}: simulate peak memory {peak / 2**20:7.1f} MiB"
              f"  {peak / os.path.getsize(written):5.2f} x its output")
        peak = peak_bytes([prog, "predict", result, log600, "-o", written])
        print(f"  {name}: predict peak memory {peak / 2**20:7.1f} MiB"
              f"  {peak / os.path.getsize(written):5.2f} x its output")
    os.remove(written)


if __name__ == "__main__":
    main()
