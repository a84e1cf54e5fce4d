#!/usr/bin/env bash
# End-to-end check of the AVR board image under simavr, with a power cut.
#
#   robot_link/emu/avr/smoke.sh FW_BUILD_DIR [HOST_BUILD_DIR]
#
# FW_BUILD_DIR: the firmware cross build (cmake -S robot_link/firmware
#   -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-avr.cmake -DODOLINK_TARGET=avr),
#   holding targets/avr/odolink_avr.elf.
# HOST_BUILD_DIR: the host project's build, with odocal and
#   robot_link/emu/avr/odocal-avr-board (default: build/ of the repository).
#   Each can be given on its own instead: ODOCAL=..., ODOCAL_AVR_BOARD=...,
#   ODOLINK_AVR_ELF=...
#   POWERCUTS=N (default 20): also kill -9 the board at random instants of a
#   push, N times, and check each boot comes up on the old set or the new.
#   (Every byte position is covered deterministically before that, with the
#   board's --cut-after-writes.)
#
# Exit 0 only if every step passed.
set -euo pipefail

fw_build=${1:?usage: smoke.sh FW_BUILD_DIR [HOST_BUILD_DIR]}
host_build=${2:-}
elf=${ODOLINK_AVR_ELF:-$fw_build/targets/avr/odolink_avr.elf}
repo=$(cd "$(dirname "$0")/../../.." && pwd)
host_build=${host_build:-$repo/build}
odocal=${ODOCAL:-$host_build/odocal}
board=${ODOCAL_AVR_BOARD:-$host_build/robot_link/emu/avr/odocal-avr-board}
powercuts=${POWERCUTS:-20}
for f in "$elf" "$odocal" "$board"; do
  [[ -n "$f" && -e "$f" ]] || { echo "smoke: missing: '${f}' (see the usage at the top)" >&2; exit 2; }
done

work=$(mktemp -d /tmp/odocal-avr-smoke.XXXXXX)
image=$work/robot.eeprom
board_pid=
cleanup() {
  if [[ -n "$board_pid" ]]; then kill -9 "$board_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

fail() { echo "FAIL: $*" >&2; exit 1; }
now() { date +%s.%N; }
ms_since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.0f", (b - a) * 1000 }'; }

# Starts the board on $image; sets board_pid and port.
start_board() {
  local out=$work/board.out
  : > "$out"
  "$board" --elf "$elf" --eeprom "$image" "$@" > "$out" 2>> "$work/board.err" &
  board_pid=$!
  for _ in $(seq 100); do
    port=$(awk '$1 == "pty" { print $2 }' "$out")
    [[ -n "$port" ]] && return 0
    kill -0 "$board_pid" 2>/dev/null || { cat "$work/board.err" >&2; fail "the board exited"; }
    sleep 0.05
  done
  fail "no pty line from the board"
}
power_cut() {
  kill -9 "$board_pid"
  wait "$board_pid" 2>/dev/null || true
  board_pid=
}
run() { echo "\$ odocal robot $*" | sed "s#$work#\$WORK#g"; "$odocal" robot "$@" --port "$port"; }

defaults=$'left_wheel_diameter_mm = 72\nright_wheel_diameter_mm = 72\ntrack_mm = 270\nticks_per_rev = 4096'
pushed=$'left_wheel_diameter_mm = 71.5\nright_wheel_diameter_mm = 72.375\ntrack_mm = 268.25\nticks_per_rev = 2048'

echo "== docs/protocol.md's push conversation, byte for byte (fresh board)"
start_board
python3 "$(dirname "$0")/replay_examples.py" "$port" "$image" odocal-avr || fail "protocol examples"
power_cut
rm -f "$image"

echo "== fresh board: $(basename "$elf"), new EEPROM image"
start_board
echo "board on $port"
run info | tee "$work/info"
grep -q '^robot: odocal-avr$' "$work/info" || fail "robot name"
grep -q '^boot_source: defaults$' "$work/info" || fail "a fresh EEPROM must boot on the defaults"
[[ "$(run get | tail -n +2)" == "$defaults" ]] || fail "defaults differ from the virtual robot's"

echo "== push"
t0=$(now)
run push left_wheel_diameter_mm=71.5 right_wheel_diameter_mm=72.375 track_mm=268.25 ticks_per_rev=2048
echo "(push took $(ms_since "$t0") ms)"
got=$(run get); echo "$got"
[[ "$(tail -n +2 <<< "$got")" == "$pushed" ]] || fail "get after push"

echo "== power cut (kill -9), reboot on the same image"
power_cut
start_board
echo "board on $port"
run info | tee "$work/info"
grep -q '^boot_source: ' "$work/info" && ! grep -q '^boot_source: defaults$' "$work/info" ||
  fail "after the power cut the board must boot from a storage slot"
got=$(run get); echo "$got"
[[ "$(tail -n +2 <<< "$got")" == "$pushed" ]] || fail "the pushed set did not survive the power cut"

echo "== rollback"
got=$(run rollback); echo "$got"
got=$(run get); echo "$got"
[[ "$(tail -n +2 <<< "$got")" == "$defaults" ]] || fail "rollback did not restore the defaults"
got=$(run get --which previous); echo "$got"
[[ "$(tail -n +2 <<< "$got")" == "$pushed" ]] || fail "previous after rollback"
power_cut
start_board
got=$(run get); echo "$got"
[[ "$(tail -n +2 <<< "$got")" == "$defaults" ]] || fail "the rollback did not survive a power cut"

echo "== a power cut right after each EEPROM byte a push writes"
# For n = 1, 2, ...: a fresh (erased) image, a board that dies like a power
# cut right after the nth EEPROM byte that changes, a push, then a normal
# boot: it must come up on the defaults or on the pushed set, whole. Ends with
# the first n the push completes under (n - 1 = the bytes a push writes).
power_cut
head -c "$(stat -c %s "$image")" /dev/zero | tr '\0' '\377' > "$work/before.eeprom"
old_n=0 new_n=0 writes=
for n in $(seq 1 200); do
  cp "$work/before.eeprom" "$image"
  start_board --cut-after-writes "$n"
  if "$odocal" robot push --port "$port" --attempts 1 \
      left_wheel_diameter_mm=71.5 right_wheel_diameter_mm=72.375 track_mm=268.25 ticks_per_rev=2048 \
      > /dev/null 2>&1 && kill -0 "$board_pid" 2>/dev/null; then
    writes=$(( n - 1 ))
    power_cut
    break
  fi
  wait "$board_pid" 2>/dev/null || true
  board_pid=
  start_board
  got=$("$odocal" robot get --port "$port")
  if [[ "$got" == "$defaults" ]]; then
    old_n=$(( old_n + 1 ))
  elif [[ "$got" == "$pushed" ]]; then
    new_n=$(( new_n + 1 ))
  else
    echo "$got"
    fail "cut after EEPROM write $n: booted on a set that is neither the old nor the new"
  fi
  power_cut
done
[[ -n "$writes" ]] || fail "the push never completed"
echo "a push writes $writes EEPROM bytes; cut after each: $old_n boots on the old set, $new_n on the new, none on anything else"
(( old_n + new_n == writes )) || fail "cut count"

if (( powercuts > 0 )); then
  echo "== $powercuts kill -9 at random instants of a push"
  cp "$work/before.eeprom" "$image"
  start_board
  current=$defaults old_n=0 new_n=0
  for i in $(seq "$powercuts"); do
    if (( i % 2 )); then
      target=$pushed
      args=(left_wheel_diameter_mm=71.5 right_wheel_diameter_mm=72.375 track_mm=268.25 ticks_per_rev=2048)
    else
      target=$defaults
      args=(left_wheel_diameter_mm=72 right_wheel_diameter_mm=72 track_mm=270 ticks_per_rev=4096)
    fi
    "$odocal" robot push --port "$port" --attempts 1 "${args[@]}" > /dev/null 2>&1 &
    push_pid=$!
    # A push that writes a whole record takes ~0.5 s here (0.24 s of it the
    # EEPROM's 3.4 ms per byte): cut anywhere in the first 0.6 s.
    sleep "0.$(printf '%03d' $(( RANDOM % 600 )))"
    power_cut
    wait "$push_pid" 2>/dev/null || true
    start_board
    got=$("$odocal" robot get --port "$port")
    if [[ "$got" == "$current" ]]; then
      old_n=$(( old_n + 1 ))
    elif [[ "$got" == "$target" ]]; then
      new_n=$(( new_n + 1 ))
      current=$target
    else
      echo "$got"
      fail "kill $i: booted on a set that is neither the old nor the new"
    fi
  done
  echo "after $powercuts kills: $old_n boots on the set before the push, $new_n on the pushed one, none on anything else"
fi

echo "== SIGTERM ends the board with status 0"
kill -TERM "$board_pid"
status=0
wait "$board_pid" || status=$?
board_pid=
(( status == 0 )) || fail "board exit status $status after SIGTERM"
echo "PASS"
