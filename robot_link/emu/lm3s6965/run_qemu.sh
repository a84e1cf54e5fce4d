#!/usr/bin/env bash
# Runs an odolink LM3S6965 image under QEMU with its serial port on a pty.
#
#   run_qemu.sh ELF FLASH_IMAGE
#
# Prints exactly one line on stdout, "pty /dev/pts/N", once QEMU has opened
# the pty (point `odocal robot ... --port /dev/pts/N` at it), then stays in
# the foreground until QEMU exits or this script gets SIGTERM/SIGINT/SIGHUP,
# which it passes on to QEMU. QEMU's own messages go to stderr. (QEMU 7.2
# prints the "char device redirected to /dev/pts/N (label serial0)" line on
# its stdout; both of its streams are read here, so either works.)
#
# FLASH_IMAGE is a host file standing in for the two flash pages of parameter
# storage (2 KB). The firmware opens it through ARM semihosting; it is
# created (erased, all 0xFF) if missing. Keep the same file across runs to
# keep the parameters; delete it for a factory-fresh robot.
#
# Environment:
#   QEMU_SYSTEM_ARM  the QEMU binary (default: qemu-system-arm)
#   QEMU_PIDFILE     if set, QEMU writes its pid there (for kill -9 tests:
#                    killing this script with SIGKILL leaves QEMU running)
#   ODOLINK_FLASH_DELAY_MS  if set, each flash erase and word program takes
#                    this many ms more (power-cut tests: see powercut.sh)
set -euo pipefail

if [[ $# -ne 2 ]]; then
  echo "usage: $0 ELF FLASH_IMAGE" >&2
  exit 2
fi
elf=$(realpath -e -- "$1")
image=$(realpath -m -- "$2")
qemu=${QEMU_SYSTEM_ARM:-qemu-system-arm}

# The image path reaches the firmware as the semihosting command line
# "odolink IMAGE" (everything after the first word is the path). Commas are
# doubled: QEMU's option syntax uses ',' as its separator.
arg_image=${image//,/,,}
semihost_args="enable=on,target=native,arg=odolink"
if [[ -n ${ODOLINK_FLASH_DELAY_MS:-} ]]; then
  semihost_args+=",arg=flash_delay_ms=$((ODOLINK_FLASH_DELAY_MS))"
fi
semihost_args+=",arg=$arg_image"

qemu_args=(
  -M lm3s6965evb
  -nographic
  -monitor none          # no monitor anywhere, in particular not on stdio
  -serial pty            # UART0 on a pty; UART1 and UART2 stay unconnected
  -semihosting-config "$semihost_args"
  -kernel "$elf"
)
if [[ -n ${QEMU_PIDFILE:-} ]]; then
  qemu_args+=(-pidfile "$QEMU_PIDFILE")
fi

fifo_dir=$(mktemp -d)
fifo=$fifo_dir/stderr
mkfifo "$fifo"

# Both QEMU streams (its messages, and semihosting console output if the
# firmware ever prints) go through the fifo to our stderr: our stdout carries
# nothing but the pty line.
"$qemu" "${qemu_args[@]}" </dev/null >"$fifo" 2>&1 &
qemu_pid=$!

forward() { kill -"$1" "$qemu_pid" 2>/dev/null || true; }
trap 'forward TERM' TERM
trap 'forward INT' INT
trap 'forward HUP' HUP

exec 3<"$fifo"
rm -rf "$fifo_dir" # the open descriptors keep the fifo alive

found=""
while IFS= read -r line <&3; do
  if [[ $line == *"char device redirected to "*"(label serial0)"* ]]; then
    dev=${line#*redirected to }
    dev=${dev%% *}
    echo "pty $dev"
    found=1
    break
  fi
  printf '%s\n' "$line" >&2
done
if [[ -z $found ]]; then
  echo "run_qemu.sh: QEMU exited before reporting the serial pty" >&2
fi

# Keep passing QEMU's later messages on, then wait for it.
cat <&3 >&2 &
cat_pid=$!
exec 3<&-

status=0
while true; do
  wait "$qemu_pid" && status=0 || status=$?
  # `wait` returns early (status > 128) when a trapped signal arrives; QEMU
  # is still running then, so wait again until it is really gone.
  if ! kill -0 "$qemu_pid" 2>/dev/null; then break; fi
done
wait "$cat_pid" 2>/dev/null || true
exit "$status"
