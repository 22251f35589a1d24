#!/usr/bin/env python3
"""host_id image make/sign/info checked with tools independent of ours:
the header read at docs/flashing.md's offsets with Python's struct, the
CRC-32s with zlib, the SHA-256 with hashlib, the Ed25519 signature with
OpenSSL. Usage: check_image_tools.py HOST_ID"""
import hashlib
import json
import os
import struct
import subprocess
import sys
import tempfile
import zlib

host_id = sys.argv[1]


def run(*args, expect=0):
    r = subprocess.run([host_id, *args], capture_output=True, text=True)
    if r.returncode != expect:
        sys.exit(f"host_id {' '.join(args)}: exit {r.returncode}, expected {expect}\n{r.stderr}")
    return r


def fail(what):
    sys.exit("FAIL: " + what)


with tempfile.TemporaryDirectory() as d:
    prog = os.path.join(d, "prog.bin")
    payload = os.urandom(70000)
    open(prog, "wb").write(payload)
    img = os.path.join(d, "fw.img")
    run("image", "make", prog, "-o", img, "--version", "2.3.4", "--build-id", "test-build")
    b = open(img, "rb").read()
    if b[:8] != b"DELTAIMG":
        fail("magic")
    hv, hs, vendor, product, revision, major, minor, patch, flags = struct.unpack_from("<HHIIIHHHH", b, 8)
    if (hv, hs, vendor, product, revision) != (1, 256, 0xDE17, 0x16, (2 << 16) | 3):
        fail(f"header fields {(hv, hs, hex(vendor), hex(product), hex(revision))}")
    if (major, minor, patch, flags) != (2, 3, 4, 0):
        fail("version or flags")
    if b[32:64].rstrip(b"\0") != b"test-build":
        fail("build id")
    length, crc = struct.unpack_from("<II", b, 64)
    if length != len(payload) or b[256:] != payload:
        fail("payload")
    if crc != zlib.crc32(payload):
        fail(f"payload CRC-32 {crc:#x} != zlib's {zlib.crc32(payload):#x}")
    if b[72:104] != hashlib.sha256(payload).digest():
        fail("payload SHA-256 differs from hashlib's")
    if struct.unpack_from("<I", b, 252)[0] != zlib.crc32(b[:252]):
        fail("header CRC-32 differs from zlib's")

    sec, pub = os.path.join(d, "s.key"), os.path.join(d, "p.key")
    run("image", "keygen", "--secret", sec, "--public", pub)
    if os.stat(sec).st_mode & 0o077:
        fail("the secret key file is readable by others")
    signed = os.path.join(d, "signed.img")
    run("image", "sign", img, "--key", sec, "-o", signed)
    s = open(signed, "rb").read()
    if struct.unpack_from("<H", s, 30)[0] != 1:
        fail("signed flag")
    # OpenSSL verifies the Ed25519 signature of bytes 0-127 (public key as
    # an X.509 SubjectPublicKeyInfo: the fixed Ed25519 prefix, then the key).
    der = bytes.fromhex("302a300506032b6570032100") + bytes.fromhex(open(pub).read().strip())
    pem = os.path.join(d, "p.pem")
    subprocess.run(["openssl", "pkey", "-pubin", "-inform", "DER", "-out", pem], input=der, check=True)
    open(os.path.join(d, "msg"), "wb").write(s[:128])
    open(os.path.join(d, "sig"), "wb").write(s[128:192])
    v = subprocess.run(["openssl", "pkeyutl", "-verify", "-pubin", "-inkey", pem, "-rawin",
                        "-in", os.path.join(d, "msg"), "-sigfile", os.path.join(d, "sig")],
                       capture_output=True, text=True)
    if v.returncode != 0:
        fail("OpenSSL does not verify host_id's signature: " + v.stdout + v.stderr)
    run("image", "info", signed, "--public-key", pub)
    info = json.loads(run("image", "info", signed, "--public-key", pub, "--json").stdout)
    if (info["version"], info["build_id"], info["program_bytes"], info["signature"], info["ok"]) != (
            "2.3.4", "test-build", len(payload), "verified", True):
        fail(f"info --json: {info}")
    if info["program_crc32"] != f"0x{zlib.crc32(payload):08X}" or \
            info["program_sha256"] != hashlib.sha256(payload).hexdigest():
        fail(f"info --json's CRC-32 or SHA-256: {info}")

    bad = bytearray(b)
    bad[256 + 1234] ^= 0x01
    open(os.path.join(d, "bad.img"), "wb").write(bad)
    r = run("image", "info", os.path.join(d, "bad.img"), expect=5)
    if "CRC-32 does not match" not in r.stderr:
        fail("info's message for a flipped bit: " + r.stderr)
    r = run("image", "info", os.path.join(d, "bad.img"), "--json", expect=5)
    if json.loads(r.stdout)["ok"] is not False:
        fail("info --json of a flipped bit: " + r.stdout)
print("host_id image: header, CRC-32, SHA-256 and Ed25519 agree with struct, zlib, hashlib and OpenSSL")
