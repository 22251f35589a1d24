#!/usr/bin/python3
"""The least-squares fit of `host_id fit --model lumped --method ls` in numpy
and scipy, for the speed comparison of docs/dev/performance.md.

  tests/bench/fit_numpy.py LOG.csv [--host-id build/bin/host_id] [--runs 3]

Does what `host_id fit LOG.csv --model lumped --method ls` does, vectorised
over samples: read the delta-log/1 file, low-pass filter q forward and
backward (4th-order Butterworth at 20 Hz), five-point differences for qd and
qdd, the lumped model's regressor (forward kinematics, Jacobian and Jdot
qdot per sample, docs/model.md), the regressor's columns and tau filtered alike,
150 samples trimmed at each end, the equations of joints slower than
0.05 rad/s left out, and numpy's lstsq. Prints its parameters next to
host_id's and the wall time of each, each in a fresh process (median of
--runs). The log must have no gaps (one segment), as the logs this
compares on do.

Needs Debian's python3-numpy and python3-scipy (run with /usr/bin/python3).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

CUTOFF_HZ = 20.0
MIN_SPEED = 0.05
SMOOTHING = 0.01
PARAMETERS = ["arm_inertia", "arm_gravity_moment", "platform_mass", "viscous_friction_1",
              "viscous_friction_2", "viscous_friction_3", "coulomb_friction_1",
              "coulomb_friction_2", "coulomb_friction_3"]

FIT_PROGRAM = r'''
import sys, json, numpy as np
from scipy import signal
path, cutoff, min_speed, w = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
meta = {}
with open(path) as f:
    skip = 0
    for line in f:
        skip += 1
        if line.startswith('#'):
            if '=' in line:
                k, v = line[1:].split('=', 1)
                meta[k.strip()] = v.strip()
            continue
        header = line.strip().split(',')
        break
data = np.loadtxt(path, delimiter=',', skiprows=skip, comments='#')
col = {n: i for i, n in enumerate(header)}
t = data[:, col['t']]
q = data[:, [col['q1'], col['q2'], col['q3']]]
tau = data[:, [col['tau1'], col['tau2'], col['tau3']]]
a, b = float(meta['upper_arm_length_m']), float(meta['forearm_length_m'])
R, r = float(meta['base_radius_m']), float(meta['platform_radius_m'])
g = float(meta.get('gravity_m_s2', 9.81))
fs = float(meta['sample_rate_hz']) if 'sample_rate_hz' in meta else 1.0 / np.median(np.diff(t))
h = 1.0 / fs
pad = int(np.ceil(3 * fs / cutoff))
sos = signal.butter(4, cutoff / (fs / 2), output='sos')
q = signal.sosfiltfilt(sos, q, axis=0, padlen=pad)
qd = np.zeros_like(q); qdd = np.zeros_like(q)
qd[2:-2] = (-q[4:] + 8 * q[3:-1] - 8 * q[1:-3] + q[:-4]) / (12 * h)
qdd[2:-2] = (-q[4:] + 16 * q[3:-1] - 30 * q[2:-2] + 16 * q[1:-3] - q[:-4]) / (12 * h * h)
# Kinematics, per sample, vectorised (docs/conventions.md).
phi = np.radians([0.0, 120.0, 240.0])
u = np.stack([np.cos(phi), np.sin(phi), np.zeros(3)], axis=1)           # (3, 3)
s, c = np.sin(q), np.cos(q)                                             # (n, 3)
elbow = (R + a * c)[:, :, None] * u[None] ; elbow[:, :, 2] = -a * s     # (n, 3, 3)
centres = elbow - r * u[None]
d21 = centres[:, 1] - centres[:, 0]; d31 = centres[:, 2] - centres[:, 0]
d = np.linalg.norm(d21, axis=1)
ex = d21 / d[:, None]
i_ = np.einsum('ij,ij->i', ex, d31)
ey = d31 - ex * i_[:, None]; j_ = np.linalg.norm(ey, axis=1); ey /= j_[:, None]
ez = np.cross(ex, ey); ez[ez[:, 2] > 0] *= -1
x = d / 2; y = (i_ ** 2 + j_ ** 2 - 2 * i_ * x) / (2 * j_)
p = centres[:, 0] + ex * x[:, None] + ey * y[:, None] + ez * np.sqrt(b * b - x * x - y * y)[:, None]
A = p[:, None, :] + r * u[None] - elbow                                  # forearms (n, 3, 3)
e = np.empty_like(A); e[:, :, 0] = -a * s * u[None, :, 0]; e[:, :, 1] = -a * s * u[None, :, 1]; e[:, :, 2] = -a * c
hh = np.empty_like(A); hh[:, :, 0] = -a * c * u[None, :, 0]; hh[:, :, 1] = -a * c * u[None, :, 1]; hh[:, :, 2] = a * s
de = np.einsum('nik,nik->ni', A, e)
Ainv = np.linalg.inv(A)
J = Ainv * de[:, None, :]
pdot = np.einsum('nij,nj->ni', J, qd)
ddot = pdot[:, None, :] - e * qd[:, :, None]
rhs = np.einsum('nik,nik->ni', A, hh) * qd ** 2 - np.einsum('nik,nik->ni', ddot, ddot)
jdqd = np.einsum('nij,nj->ni', Ainv, rhs)
pdd_g = np.einsum('nij,nj->ni', J, qdd) + jdqd; pdd_g[:, 2] += g
platform = np.einsum('nji,nj->ni', J, pdd_g)                             # J^T (pdd - g)
n = len(t)
psi = np.zeros((n, 3, 9))
psi[:, :, 0] = qdd; psi[:, :, 1] = -c; psi[:, :, 2] = platform
for k in range(3):
    psi[:, k, 3 + k] = qd[:, k]; psi[:, k, 6 + k] = np.tanh(qd[:, k] / w)
psi = signal.sosfiltfilt(sos, psi.reshape(n, 27), axis=0, padlen=pad).reshape(n, 3, 9)
tau = signal.sosfiltfilt(sos, tau, axis=0, padlen=pad)
keep = slice(pad, n - pad)
speed = np.abs(qd[keep]).reshape(-1)
rows, y_ = psi[keep].reshape(-1, 9), tau[keep].reshape(-1)
fast = speed >= min_speed
beta = np.linalg.lstsq(rows[fast], y_[fast], rcond=None)[0]
print(json.dumps(list(beta)))
'''


def run(cmd):
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        sys.exit(f"fit_numpy: {' '.join(cmd)} failed: {done.stderr}")
    return seconds, done.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log")
    ap.add_argument("--host-id", default="build/bin/host_id")
    ap.add_argument("--runs", type=int, default=3)
    a = ap.parse_args()
    numpy_cmd = ["/usr/bin/python3", "-c", FIT_PROGRAM, a.log, str(CUTOFF_HZ), str(MIN_SPEED),
                 str(SMOOTHING)]
    host_cmd = [a.host_id, "fit", a.log, "--model", "lumped", "--method", "ls", "--json",
                "--quiet"]
    times = {"numpy/scipy": [], "host_id": []}
    for _ in range(a.runs):  # interleaved, so that both see the same load
        seconds, out = run(numpy_cmd)
        times["numpy/scipy"].append(seconds)
        beta_numpy = json.loads(out)
        seconds, out = run(host_cmd)
        times["host_id"].append(seconds)
        beta_host = json.loads(out)["parameters"]
    print(f"{os.path.basename(a.log)} ({os.path.getsize(a.log) / 1e6:.1f} MB), "
          f"median of {a.runs} fresh processes")
    for k, v in times.items():
        print(f"  {k:12s} {statistics.median(v):7.3f} s")
    ratio = statistics.median(times["numpy/scipy"]) / statistics.median(times["host_id"])
    print(f"  host_id is {ratio:.2f}x faster")
    print("  parameter                 numpy/scipy     host_id")
    for name, value in zip(PARAMETERS, beta_numpy):
        print(f"  {name:24s} {value:11.6g} {beta_host[name]:11.6g}")


if __name__ == "__main__":
    main()
