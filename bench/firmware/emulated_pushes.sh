#!/usr/bin/env bash
# The firmware library on the emulated ATmega328P (and the LM3S6965), at the
# counts the suite keeps small: 200 pushes through a line corrupting 1 % of
# the bytes, 50 power cuts at random instants of a push. Prints the summary
# lines that docs/protocol.md records. About 7 minutes per part, 13 for both.
#
#   bench/firmware/emulated_pushes.sh [BUILD_DIR] [avr|lm3s6965|all]
set -euo pipefail
build=${1:-build}
which=${2:-avr}
test_bin="$build/tests/robot_link/link_emulated_test"
[[ -x $test_bin ]] || { echo "emulated_pushes: $test_bin not built (cmake --build $build)" >&2; exit 2; }
case $which in
  avr|lm3s6965) filter="*Corrupting*/$which:*PowerCut*/$which" ;;
  all) filter="*Corrupting*:*PowerCut*" ;;
  *) echo "emulated_pushes: target '$which' is not avr, lm3s6965 or all" >&2; exit 2 ;;
esac
export ODOCAL_BINARY=${ODOCAL_BINARY:-$build/odocal}
export ODOCAL_EMU_PUSHES=${ODOCAL_EMU_PUSHES:-200}
export ODOCAL_EMU_KILLS=${ODOCAL_EMU_KILLS:-50}
start=$(date +%s)
"$test_bin" --gtest_filter="$filter" | grep -E '^\[emulated|^\[  (PASSED|FAILED)|OK \]'
echo "elapsed: $(( $(date +%s) - start )) s"
