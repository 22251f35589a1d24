#!/usr/bin/env python3
"""Checks golden_host's crc32-sha256 lines against Python's zlib and hashlib,
an implementation independent of ours. Usage: check_hashes.py GOLDEN_HOST"""
import hashlib
import subprocess
import sys
import zlib

data = bytes(((i * 151 + 17) & 0xFF) for i in range(300))
out = subprocess.run([sys.argv[1]], check=True, capture_output=True, text=True).stdout
lines = [l.split() for l in out.splitlines() if l.startswith("crc32-sha256 ")]
if len(lines) < 6:
    sys.exit(f"expected 6 crc32-sha256 lines, found {len(lines)}")
for words in lines:
    n = int(words[1])
    digest = hashlib.sha256(data[:n]).digest()
    want = [zlib.crc32(data[:n])] + [int.from_bytes(digest[i:i + 4], "big") for i in range(0, 32, 4)]
    got = [int(w) for w in words[2:]]
    if got != want:
        sys.exit(f"{n} bytes: ours {got}, Python's {want}")
print(f"{len(lines)} CRC-32/SHA-256 vectors match Python's zlib and hashlib")
