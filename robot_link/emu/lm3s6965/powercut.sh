#!/usr/bin/env bash
# Power cuts during parameter commits, on the LM3S6965 image under QEMU.
#
#   powercut.sh BUILD_DIR [ROUNDS]      (default 20 rounds)
#
# Each round pushes a new set (every value different from the active one)
# and kill -9's QEMU while the firmware writes the record to flash, then boots
# the same flash image again and checks olf's promise: the robot comes back
# on the old set or the new one, never a mix, and never loses a commit the
# host was told succeeded.
#
# Aiming the cut: flash is slowed down (ODOLINK_FLASH_DELAY_MS, default 5 ms
# per erase and per word, so a record takes ~100 ms to write); a watcher
# polls the image file and, from the first change it sees (the erase or the
# first word of the new record), waits a random 0..CUT_SPREAD_MS (default
# 120) ms and sends SIGKILL. Each round prints what the cut left in the two
# flash slots: erased, a valid record (its generation) or torn.
set -euo pipefail

if [[ $# -lt 1 || $# -gt 2 ]]; then
  echo "usage: $0 BUILD_DIR [ROUNDS]" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../../.." && pwd)
elf=$(realpath -e "$1/targets/lm3s6965/odolink_lm3s6965.elf")
rounds=${2:-20}
odocal=${ODOCAL:-$(command -v odocal || echo "$repo/build/odocal")}
[[ -x $odocal ]] || { echo "powercut: no odocal binary ($odocal); set ODOCAL" >&2; exit 2; }
export ODOLINK_FLASH_DELAY_MS=${ODOLINK_FLASH_DELAY_MS:-5}

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
fail() { echo "POWERCUT FAILED: $*" >&2; exit 1; }

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
}

power_cut() {
  kill -KILL "$qemu_pid"
  wait "$launcher_pid" 2>/dev/null || true
  launcher_pid=""
}

# The two slots of the image: "erased", "gen N" (a valid record) or "torn"
# (neither: a record cut short). Record layout: olf_record_build, CRC-32 of
# the first 66 bytes in bytes 66..69.
slots() {
  python3 - "$image" <<'PY'
import struct, sys, zlib
d = open(sys.argv[1], "rb").read()
out = []
for name, base in (("A", 0), ("B", 1024)):
    page = d[base:base + 1024]
    if page == b"\xff" * 1024:
        out.append(f"{name}: erased")
        continue
    rec = page[:70]
    ok = zlib.crc32(rec[:66]) == struct.unpack("<I", rec[66:70])[0]
    out.append(f"{name}: gen {struct.unpack('<I', rec[4:8])[0]}" if ok else f"{name}: torn")
print(", ".join(out))
PY
}

# Waits for the image to change, then a random delay, then kill -9 QEMU.
# Prints the delay it chose (ms after the first change; "none" if the image
# did not change within 5 s, in which case it kills anyway).
cut_during_write() {
  python3 - "$image" "$qemu_pid" "${CUT_SPREAD_MS:-120}" <<'PY'
import os, random, signal, sys, time
path, pid, spread = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
before = open(path, "rb").read()
deadline = time.monotonic() + 5.0
seen = False
while time.monotonic() < deadline:
    if open(path, "rb").read() != before:
        seen = True
        break
    time.sleep(0.001)
delay = random.randint(0, spread) if seen else 0
time.sleep(delay / 1000.0)
os.kill(pid, signal.SIGKILL)
print(delay if seen else "none")
PY
}

# Expected `odocal robot get` output for round $1 (values exact in binary,
# so printing them is unambiguous).
expected() {
  python3 - "$1" <<'PY'
import sys
i = int(sys.argv[1])
print("left_wheel_diameter_mm = %.17g" % (70 + i * 0.125))
print("right_wheel_diameter_mm = %.17g" % (71 + i * 0.0625))
print("track_mm = %.17g" % (250 + i))
print("ticks_per_rev = %d" % (4000 + i))
PY
}

start_robot
"$odocal" robot push --port "$pty" left_wheel_diameter_mm=70 right_wheel_diameter_mm=71 \
  track_mm=250 ticks_per_rev=4000 >/dev/null
echo "flash delay ${ODOLINK_FLASH_DELAY_MS} ms per erase/word, cut 0..${CUT_SPREAD_MS:-120} ms after the first flash change"

old=$(expected 0)
n_old=0 n_new=0 n_torn=0
for ((r = 1; r <= rounds; ++r)); do
  new=$(expected "$r")
  "$odocal" robot push --port "$pty" \
    "left_wheel_diameter_mm=$(sed -n 's/^left_wheel_diameter_mm = //p' <<<"$new")" \
    "right_wheel_diameter_mm=$(sed -n 's/^right_wheel_diameter_mm = //p' <<<"$new")" \
    "track_mm=$(sed -n 's/^track_mm = //p' <<<"$new")" \
    "ticks_per_rev=$(sed -n 's/^ticks_per_rev = //p' <<<"$new")" >/dev/null 2>&1 &
  push_pid=$!
  cut_ms=$(cut_during_write)
  wait "$launcher_pid" 2>/dev/null || true
  launcher_pid=""
  push_rc=0
  wait "$push_pid" || push_rc=$?
  left=$(slots)
  start_robot
  now=$("$odocal" robot get --port "$pty")
  if [[ $now == "$new" ]]; then
    verdict=new
    n_new=$((n_new + 1))
    old=$new
  elif [[ $now == "$old" ]]; then
    verdict=old
    n_old=$((n_old + 1))
    [[ $push_rc -ne 0 ]] || fail "round $r: push reported success, robot came back on the old set"
  else
    echo "$now" >&2
    fail "round $r: robot came back on neither the old nor the new set"
  fi
  [[ $left == *torn* ]] && n_torn=$((n_torn + 1))
  printf 'round %2d: cut %4s ms into the write, push rc %d, flash left: %-28s -> boots on the %s set\n' \
    "$r" "$cut_ms" "$push_rc" "$left" "$verdict"
done
echo "POWERCUT OK: $rounds cuts, $n_new on the new set, $n_old on the old set, $n_torn left a torn record"
