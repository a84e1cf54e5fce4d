#!/usr/bin/env bash
# End-to-end check of the LM3S6965 firmware under QEMU with the odocal host
# tool: persistence across a power cut, and rollback.
#
#   smoke.sh BUILD_DIR
#
# BUILD_DIR is the cross build (cmake ... -DODOLINK_TARGET=lm3s6965); the
# image is BUILD_DIR/targets/lm3s6965/odolink_lm3s6965.elf. The host tool is
# $ODOCAL (default: odocal on PATH, else build/odocal of the repository).
#
# Steps: fresh flash image -> info -> push a set -> get -> kill -9 QEMU (a
# power cut) -> restart on the same image -> get shows the pushed set (booted
# from flash) -> rollback -> get shows the defaults again -> power cut and
# restart once more -> the rolled-back set persisted too.
# Exit status 0 only if every check passed.
set -euo pipefail

if [[ $# -ne 1 ]]; then
  echo "usage: $0 BUILD_DIR" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../../.." && pwd)
elf=$(realpath -e "$1/targets/lm3s6965/odolink_lm3s6965.elf")
if [[ -n ${ODOCAL:-} ]]; then
  odocal=$ODOCAL
elif command -v odocal >/dev/null; then
  odocal=$(command -v odocal)
else
  odocal=$repo/build/odocal
fi
[[ -x $odocal ]] || { echo "smoke: no odocal binary ($odocal); set ODOCAL" >&2; exit 2; }

work=$(mktemp -d)
image=$work/flash.img
launcher_pid=""
qemu_pid=""
pty=""

cleanup() {
  if [[ -n $launcher_pid ]]; then kill -TERM "$launcher_pid" 2>/dev/null || true; wait "$launcher_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

fail() { echo "SMOKE FAILED: $*" >&2; exit 1; }

start_robot() {
  rm -f "$work/qemu.pid" "$work/launcher.out"
  QEMU_PIDFILE=$work/qemu.pid "$here/run_qemu.sh" "$elf" "$image" >"$work/launcher.out" 2>>"$work/qemu.log" &
  launcher_pid=$!
  local i
  for ((i = 0; i < 100; ++i)); do
    if grep -q '^pty ' "$work/launcher.out" 2>/dev/null && [[ -s $work/qemu.pid ]]; then break; fi
    sleep 0.1
  done
  pty=$(sed -n 's/^pty //p' "$work/launcher.out")
  [[ -n $pty ]] || fail "run_qemu.sh printed no pty line"
  qemu_pid=$(cat "$work/qemu.pid")
  echo "== robot up: $pty (qemu pid $qemu_pid)"
}

power_cut() {
  echo "== kill -9 qemu (pid $qemu_pid): power cut"
  kill -KILL "$qemu_pid"
  wait "$launcher_pid" 2>/dev/null || true
  launcher_pid=""
}

robot() {
  echo "\$ odocal robot $*"
  "$odocal" robot "$@" --port "$pty"
}

expect_set() { # expected values of the four parameters, in table order
  local out
  out=$(robot get)
  echo "$out"
  grep -Eq "^left_wheel_diameter_mm = $1\$" <<<"$out" || fail "left_wheel_diameter_mm is not $1"
  grep -Eq "^right_wheel_diameter_mm = $2\$" <<<"$out" || fail "right_wheel_diameter_mm is not $2"
  grep -Eq "^track_mm = $3\$" <<<"$out" || fail "track_mm is not $3"
  grep -Eq "^ticks_per_rev = $4\$" <<<"$out" || fail "ticks_per_rev is not $4"
}

echo "== image: $elf"
echo "== fresh flash image: $image (created by the firmware, erased)"
start_robot
info=$(robot info)
echo "$info"
grep -q '^robot: odocal-lm3s6965$' <<<"$info" || fail "robot name"
grep -q '^boot_source: defaults$' <<<"$info" || fail "a fresh image must boot on the defaults"
expect_set 72 72 270 4096

t0=$(date +%s%N)
robot push left_wheel_diameter_mm=72.31 right_wheel_diameter_mm=71.86 track_mm=268.9 ticks_per_rev=4096
t1=$(date +%s%N)
echo "== push took $(((t1 - t0) / 1000000)) ms"
expect_set '72\.31(0*[0-9]*)?' '71\.8(6|59999*[0-9]*)' '268\.(9|89999*[0-9]*)' 4096

power_cut
start_robot
info=$(robot info)
echo "$info"
grep -q '^boot_source: storage$' <<<"$info" || fail "after the power cut the robot must boot from flash"
expect_set '72\.31(0*[0-9]*)?' '71\.8(6|59999*[0-9]*)' '268\.(9|89999*[0-9]*)' 4096

robot rollback
expect_set 72 72 270 4096

power_cut
start_robot
robot info | grep -E "^(\$|boot_source)"
expect_set 72 72 270 4096

echo "== flash image after the test (slot A page, slot B page; first 80 bytes of each):"
od -An -tx1 -N 80 "$image"
od -An -tx1 -j 1024 -N 80 "$image"
echo "SMOKE OK"
