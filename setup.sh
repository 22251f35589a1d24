#!/usr/bin/env bash
# Installs every build and test dependency of the project from Debian
# bookworm's packages. Safe to run twice: it installs only what is missing.
# As root it runs apt-get itself; otherwise it prints the exact line to run.
set -euo pipefail

packages=(
  # build
  build-essential cmake ninja-build pkg-config
  # libraries
  libeigen3-dev nlohmann-json3-dev libcli11-dev libfast-float-dev
  # the multibody robot of the emulator and `host_id simulate`
  libmujoco-dev
  # controller I/O: Modbus and GPIO
  libmodbus-dev libgpiod-dev
  # CANopen device descriptions (EDS files are INI)
  libinih-dev
  # firmware image signatures (Ed25519); openssl checks them in the tests
  libsodium-dev openssl
  # tests and benchmarks (python3 runs three tests and the fit's speed
  # bench; numpy and scipy the least-squares comparison, tests/bench/fit_numpy.py)
  libgtest-dev libgmock-dev libbenchmark-dev python3 python3-numpy python3-scipy
  # independent Modbus masters: mbpoll (RTU) and pymodbus (TCP; its client
  # module imports serial_asyncio, which Debian only recommends)
  mbpoll python3-pymodbus python3-serial-asyncio
  # independent readers of a session's candump in the HIL tests: python-can,
  # canmatrix (the DBC) and tshark's CANopen dissector
  python3-can python3-canmatrix tshark
  # the firmware core on Cortex-M4, run on qemu
  gcc-arm-none-eabi libstdc++-arm-none-eabi-newlib libnewlib-arm-none-eabi qemu-system-arm
  # real vcan for the HIL tests (hil/vcan-run: a qemu VM where the kernel has no CAN)
  qemu-system-x86 busybox-static iproute2 can-utils
  # code hygiene
  clang-format clang-tidy
  # fuzzing (tests/fuzz): clang's libFuzzer and sanitizer runtimes
  clang libclang-rt-14-dev libfuzzer-14-dev
  # the HIL VM's gpio-sim module is built with the kernel's headers (hil/vcan-run)
  make xz-utils
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages are installed"
  exit 0
fi

cmd="apt-get install -y --no-install-recommends ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
  echo "setup: missing packages: ${missing[*]}" >&2
  echo "setup: run as root:  apt-get update && DEBIAN_FRONTEND=noninteractive $cmd" >&2
  exit 1
fi

echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
# shellcheck disable=SC2086
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
