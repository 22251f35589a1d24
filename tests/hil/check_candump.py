#!/usr/bin/python3
"""A session's candump checked by tools that share no code with ours.

  check_candump.py --dbc docs/delta.dbc --candump session.log --log path1.csv

- python-can (python3-can) reads the candump -L file;
- canmatrix (python3-canmatrix) reads docs/delta.dbc and decodes every
  frame: each must have its message, with the message's length; the angles
  and torques of LOG_A, LOG_B and LOG_C (and the arm angles of LOG_D and
  LOG_E, where the log has qa1..qa3) must equal the recorded log's, row by
  row;
- tshark's CANopen dissector (Debian's tshark) decodes the same file: no
  frame is malformed or flagged as an error, no SDO transfer is aborted,
  every SDO request is answered before the node's next one, the NMT start
  comes after the last bring-up SDO and before the first SYNC, and each
  drive's heartbeat says operational after it.

Prints what it checked; exits 1 naming the first frame or row that fails,
2 on a usage error.
"""
import argparse
import csv
import logging
import math
import subprocess
import sys

# canmatrix warns, on import, of every file format whose module Debian's
# package lacks (arxml, xls, ...); only DBC is read here.
logging.getLogger("canmatrix.formats").setLevel(logging.ERROR)

import can  # noqa: E402  (after the logger's level)
import canmatrix  # noqa: E402
import canmatrix.formats  # noqa: E402

SEQ_MODULO = 1 << 15  # the log frames' seq field (docs/protocol.md)
DRIVE_NODES = (1, 2, 3)
NMT_START = 1
HEARTBEAT_OPERATIONAL = 5


def fail(message):
    print(f"check_candump: {message}", file=sys.stderr)
    sys.exit(1)


def read_frames(path):
    frames = list(can.CanutilsLogReader(path))
    if not frames:
        fail(f"{path}: no frames")
    return frames


def decode_with_dbc(dbc_path, frames):
    """Every frame decoded: {message name: count}, and the log frames'
    signals by (unwrapped) seq."""
    db = canmatrix.formats.loadp_flat(dbc_path)
    counts = {}
    records = {}
    last_seq = {}
    for n, f in enumerate(frames, 1):
        if f.is_extended_id:
            fail(f"frame {n}: extended ID {f.arbitration_id:#x}; the bus uses 11-bit IDs")
        message = db.frame_by_id(canmatrix.ArbitrationId(f.arbitration_id))
        if message is None:
            fail(f"frame {n}: ID {f.arbitration_id:#05x} has no message in {dbc_path}")
        if f.dlc != message.size:
            fail(f"frame {n}: {message.name} has {f.dlc} bytes, the DBC says {message.size}")
        counts[message.name] = counts.get(message.name, 0) + 1
        if message.name in ("LOG_A", "LOG_B", "LOG_C", "LOG_D", "LOG_E"):
            values = {k: float(v.phys_value) for k, v in message.decode(bytes(f.data)).items()}
            seq = int(values.pop("seq"))
            base = last_seq.get(message.name, (0, -1))
            wraps, previous = base
            if seq < previous:
                wraps += 1
            last_seq[message.name] = (wraps, seq)
            records.setdefault(wraps * SEQ_MODULO + seq, {}).update(values)
    return counts, records


def compare_with_log(log_path, records):
    rows = 0
    with open(log_path, newline="") as f:
        lines = (line for line in f if not line.startswith("#"))
        for row in csv.DictReader(lines):
            seq = int(row["seq"])
            got = records.get(seq)
            if got is None:
                fail(f"{log_path}: seq {seq} has no log frames in the candump")
            arm = ("qa1", "qa2", "qa3") if "qa1" in row else ()
            for column in ("q1", "q2", "q3", "tau1", "tau2", "tau3") + arm:
                want = float(row[column])
                if column not in got:
                    fail(f"{log_path}: seq {seq}: no {column} in the candump's log frames")
                if not math.isclose(got[column], want, rel_tol=1e-12, abs_tol=1e-12):
                    fail(f"{log_path}: seq {seq}: {column} {want!r} in the log, "
                         f"{got[column]!r} decoded by the DBC")
            rows += 1
    if rows == 0:
        fail(f"{log_path}: no rows")
    return rows


TSHARK_FIELDS = ("frame.number", "_ws.col.Protocol", "canopen.function_code", "canopen.node_id",
                 "canopen.sdo.abort_code", "canopen.nmt_ctrl.cd", "canopen.nmt_guard.state",
                 "_ws.malformed", "_ws.expert.severity")


def tshark_rows(path):
    cmd = ["tshark", "-r", path, "-d", "can.subdissector,canopen", "-T", "fields",
           "-E", "separator=/t", "-E", "occurrence=f"]
    for field in TSHARK_FIELDS:
        cmd += ["-e", field]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        fail(f"tshark failed: {done.stderr.strip()}")
    for line in done.stdout.splitlines():
        yield dict(zip(TSHARK_FIELDS, line.split("\t")))


def check_canopen(path, frames):
    """Returns what tshark saw, after the checks of the docstring."""
    waiting = {}  # node -> frame number of its unanswered SDO request
    first_sync = nmt_start = last_bring_up_sdo = None
    operational_after_start = set()
    seen = 0
    # tshark's function codes: 0 NMT, 1 SYNC/EMCY, 11 SDO response (0x580),
    # 12 SDO request (0x600), 14 NMT error control (heartbeat).
    for row in tshark_rows(path):
        seen += 1
        n = int(row["frame.number"])
        if row["_ws.col.Protocol"] != "CANopen":
            fail(f"frame {n}: tshark decodes it as {row['_ws.col.Protocol']}, not CANopen")
        if row["_ws.malformed"] or row["_ws.expert.severity"]:
            fail(f"frame {n}: tshark flags it: malformed {row['_ws.malformed']!r}, "
                 f"expert severity {row['_ws.expert.severity']!r}")
        if row["canopen.sdo.abort_code"]:
            fail(f"frame {n}: SDO abort {row['canopen.sdo.abort_code']}")
        fc = int(row["canopen.function_code"], 0)
        node = int(row["canopen.node_id"] or "0", 0)
        if fc == 12:
            if node in waiting:
                fail(f"frame {n}: SDO request to node {node} while frame "
                     f"{waiting[node]}'s is unanswered")
            waiting[node] = n
            if first_sync is None:
                last_bring_up_sdo = n
        elif fc == 11:
            if waiting.pop(node, None) is None:
                fail(f"frame {n}: SDO response from node {node} to no request")
        elif fc == 0 and row["canopen.nmt_ctrl.cd"] and int(row["canopen.nmt_ctrl.cd"], 0) == NMT_START:
            nmt_start = nmt_start or n
        elif fc == 1 and frames[n - 1].arbitration_id == 0x080 and first_sync is None:
            first_sync = n
        elif fc == 14 and nmt_start and node in DRIVE_NODES and row["canopen.nmt_guard.state"]:
            if int(row["canopen.nmt_guard.state"], 0) == HEARTBEAT_OPERATIONAL:
                operational_after_start.add(node)
    if seen != len(frames):
        fail(f"tshark read {seen} frames, python-can {len(frames)}")
    if nmt_start is None or first_sync is None or last_bring_up_sdo is None:
        fail(f"no NMT start ({nmt_start}), bring-up SDO ({last_bring_up_sdo}) or SYNC ({first_sync})")
    if not last_bring_up_sdo < nmt_start < first_sync:
        fail(f"order: last bring-up SDO at frame {last_bring_up_sdo}, NMT start at {nmt_start}, "
             f"first SYNC at {first_sync}")
    if operational_after_start != set(DRIVE_NODES):
        fail(f"heartbeats saying operational after the NMT start only from nodes "
             f"{sorted(operational_after_start)}")
    return nmt_start, first_sync


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dbc", required=True)
    ap.add_argument("--candump", required=True)
    ap.add_argument("--log", required=True)
    a = ap.parse_args()
    frames = read_frames(a.candump)
    counts, records = decode_with_dbc(a.dbc, frames)
    rows = compare_with_log(a.log, records)
    nmt_start, first_sync = check_canopen(a.candump, frames)
    print(f"check_candump: {len(frames)} frames, every one a message of the DBC "
          f"({len(counts)} messages seen); {rows} log rows equal the decoded LOG_A/B/C"
          f"{'/D/E' if counts.get('LOG_D') else ''}; "
          f"tshark: all CANopen, no malformed frame, no SDO abort, NMT start at frame "
          f"{nmt_start} after the bring-up SDOs, first SYNC at {first_sync}, drives "
          f"{', '.join(map(str, DRIVE_NODES))} operational")


if __name__ == "__main__":
    main()
