#!/usr/bin/env bash
# Installs the Debian 12 packages odocal builds against, only those missing.
# Safe to run again: when everything is present it does nothing and asks no mirror.
set -euo pipefail
#   bash scripts/install-deps.sh            everything: the build, the tests, the benchmarks, the firmware
#   bash scripts/install-deps.sh --runtime  only what building and running odocal needs (README's first command)
mode=all
case "${1:-}" in
  "" | --all) mode=all ;;
  --runtime) mode=runtime ;;
  *) echo "install-deps: unknown option '$1' (--runtime or --all)" >&2; exit 2 ;;
esac
packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libceres-dev
  libopencv-dev libapriltag-dev
  libjpeg-dev  # the camera simulator's MJPEG (vision), without OpenCV's image codecs
  libcli11-dev libyaml-cpp-dev nlohmann-json3-dev libboost-dev
  libcpp-httplib-dev  # the live view's HTTP server (rig/live)
  libsqlite3-dev libpq-dev libssl-dev  # the record store (rig/records): SQLite, PostgreSQL's client, SHA-256
  ffmpeg  # H.264 at a chosen quality: OpenCV 4.6 pins x264 at CRF 23 (docs/vision.md)
)
if [[ $mode == all ]]; then
  packages+=(
    libgtest-dev libgmock-dev libbenchmark-dev
    clang-format git  # FormatCheck: the last commit's C/C++ lines against .clang-format (tests/app)
    chromium  # headless, for the live view's screenshot test (tests/live)
    postgresql  # a server store_test starts of its own (tests/records/postgres_server.h)
    # The firmware library on microcontrollers, in emulation (robot_link/firmware, cmake/Firmware.cmake)
    gcc-avr binutils-avr avr-libc simavr libsimavr-dev libsimavrparts1 arduino-core-avr
    gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm
  )
fi
missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages present ($mode)"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
if [[ $(id -u) -ne 0 ]]; then
  echo "install-deps: need root to install packages (run as root or with sudo)" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
