#!/usr/bin/python3
"""Debian's pymodbus, a Modbus implementation that shares no code with ours
or with libmodbus, as a Modbus TCP client of the controller's server.

  pymodbus_client.py --port PORT --inputs N --holdings M --version-address A
                     --version V --write-address W --write-value X --bad-value B

It reads every input and holding register (in requests of at most 125), the
map version at A, writes X to holding register W with function 6 and reads
it back, writes it again with function 16, and checks the exceptions: 02
for a read past the input table, 03 for value B at W, 01 for coils
(function 1, not served). Prints one line per check; exits 1 at the first
that fails.
"""
import argparse
import logging
import sys

logging.getLogger("pymodbus").setLevel(logging.CRITICAL)

from pymodbus.client import ModbusTcpClient  # noqa: E402  (after the logger's level)

MAX_READ = 125  # registers per read (Modbus application protocol, 6.3 and 6.4)
UNIT = 1


def fail(message):
    print(f"pymodbus_client: {message}", file=sys.stderr)
    sys.exit(1)


def read_all(read, count, what):
    values = []
    for start in range(0, count, MAX_READ):
        n = min(MAX_READ, count - start)
        r = read(start, n, slave=UNIT)
        if r.isError():
            fail(f"reading {what} {start}..{start + n - 1}: {r}")
        values += r.registers
    return values


def exception_code(response):
    return getattr(response, "exception_code", None) if response.isError() else None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name in ("port", "inputs", "holdings", "version-address", "version", "write-address",
                 "write-value", "bad-value"):
        ap.add_argument("--" + name, type=int, required=True)
    a = ap.parse_args()
    client = ModbusTcpClient("127.0.0.1", port=a.port, timeout=5, retries=0)
    if not client.connect():
        fail(f"cannot connect to 127.0.0.1:{a.port}")
    inputs = read_all(client.read_input_registers, a.inputs, "input registers")
    if inputs[a.version_address] != a.version:
        fail(f"input register {a.version_address} is {inputs[a.version_address]}, "
             f"the map version is {a.version}")
    print(f"ok: {len(inputs)} input registers, map version {inputs[a.version_address]}")
    holdings = read_all(client.read_holding_registers, a.holdings, "holding registers")
    print(f"ok: {len(holdings)} holding registers")

    r = client.write_register(a.write_address, a.write_value, slave=UNIT)
    if r.isError():
        fail(f"function 6 to holding register {a.write_address}: {r}")
    back = client.read_holding_registers(a.write_address, 1, slave=UNIT)
    if back.isError() or back.registers != [a.write_value]:
        fail(f"holding register {a.write_address} reads back {back}, wrote {a.write_value}")
    r = client.write_registers(a.write_address, [a.write_value], slave=UNIT)
    if r.isError():
        fail(f"function 16 to holding register {a.write_address}: {r}")
    print(f"ok: holding register {a.write_address} written (functions 6 and 16) and read back")

    checks = (
        ("a read past the input table", 2,
         client.read_input_registers(a.inputs - 1, 2, slave=UNIT)),
        (f"value {a.bad_value} at holding register {a.write_address}", 3,
         client.write_register(a.write_address, a.bad_value, slave=UNIT)),
        ("coils (function 1)", 1, client.read_coils(0, 1, slave=UNIT)),
    )
    for what, want, response in checks:
        got = exception_code(response)
        if got != want:
            fail(f"{what}: exception {got}, expected {want:02d} ({response})")
        print(f"ok: {what}: exception {want:02d}")
    client.close()


if __name__ == "__main__":
    main()
