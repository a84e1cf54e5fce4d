#!/usr/bin/env bash
# The live view's cost (docs/performance.md, "Live view"): frames/s of `odocal watch` on a
# 1080p clip read as fast as it decodes, with nobody on the page, with a plain MJPEG client
# (curl on /stream.mjpg: the server's encoding alone), and with headless Chromium showing the
# page over MJPEG (/?mjpeg=1) and as it opens by default (frame.jpg when the frame changes).
# Each client connects during watch's --delay-s, before the first frame is read. The machine's
# other load moves frames/s; the CPU time watch used (decoder, vision, server threads) does not.
#
#   bash bench/live/watch_fps.sh [OUT_DIR]      # renders the clip once (~3 min), then ~1.5 min
set -euo pipefail
cd "$(dirname "$0")/../.."
ODOCAL=${ODOCAL:-./build/odocal}
OUT=${1:-/tmp/odocal_watch_bench}
if [[ ! -f $OUT/sim/recording.mp4 ]]; then
  echo "rendering bench/live/watch_1080p.yaml into $OUT/sim ..."
  "$ODOCAL" simulate --scenario bench/live/watch_1080p.yaml --out "$OUT/sim" >/dev/null
fi

# run LABEL CLIENT [WATCH_ARGS...]: CLIENT is "none", "curl", "chromium-mjpeg" or "chromium-page".
run() {
  local label=$1 client=$2 line url summary client_pid=
  shift 2
  coproc WATCH { exec /usr/bin/time -f "cpu_s %U %S" "$ODOCAL" watch "$OUT/sim/recording.mp4" \
    --calibration "$OUT/sim/camera.yaml" --tag tag36h11:5:80:150 --port 0 --delay-s 3 "$@" 2>&1; }
  read -r line <&"${WATCH[0]}"
  url=${line#live view: }
  local chromium=(chromium --headless=new --no-sandbox --disable-gpu --disable-dev-shm-usage
                  --user-data-dir="$OUT/chromium" --window-size=1280,900)
  case $client in
    curl) curl -s -o "$OUT/stream.mjpg" "${url}stream.mjpg" & client_pid=$! ;;
    chromium-mjpeg) "${chromium[@]}" "${url}?mjpeg=1" >/dev/null 2>&1 & client_pid=$! ;;
    chromium-page) "${chromium[@]}" "$url" >/dev/null 2>&1 & client_pid=$! ;;
  esac
  read -r summary <&"${WATCH[0]}"
  local cpu user sys
  read -r cpu user sys <&"${WATCH[0]}"
  wait "$WATCH_PID" || true
  if [[ -n $client_pid ]]; then kill "$client_pid" 2>/dev/null || true; wait "$client_pid" 2>/dev/null || true; fi
  local parts=""
  if [[ $client == curl ]]; then
    parts=" ($(grep -a -o -- '--odocal-frame' "$OUT/stream.mjpg" | wc -l) MJPEG parts received)"
  fi
  local frames seconds
  frames=$(sed -E 's/^watched ([0-9]+) frames in ([0-9.]+) s.*/\1/' <<<"$summary")
  seconds=$(sed -E 's/^watched ([0-9]+) frames in ([0-9.]+) s.*/\2/' <<<"$summary")
  printf '%-34s %s; watch used %s%s\n' "$label:" "$summary" \
    "$(awk -v u="$user" -v s="$sys" -v n="$frames" -v t="$seconds" \
       'BEGIN { printf "%.1f ms of CPU a frame, %.0f %% of a core", 1000 * (u + s) / n, 100 * (u + s) / t }')" \
    "$parts"
}

echo "as fast as the clip decodes:"

run "nobody on the page" none
run "curl on /stream.mjpg" curl
run "Chromium, the page over MJPEG" chromium-mjpeg
run "Chromium, the page (frame.jpg)" chromium-page
echo "at the camera's 30 fps (--realtime, the first 15 s):"
run "nobody on the page" none --realtime --seconds 15
run "Chromium, the page over MJPEG" chromium-mjpeg --realtime --seconds 15
run "Chromium, the page (frame.jpg)" chromium-page --realtime --seconds 15
