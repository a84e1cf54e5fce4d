#!/bin/bash
# Records the same-behaviour snapshot: runs every line of commands.txt with BUILD_DIR/odocal
# and keeps stdout and the text files each case writes under tests/app/golden/NAME/.
# Run it only when a change of behaviour is intended, and say so in the commit.
set -euo pipefail
build=$(cd "${1:?usage: record.sh BUILD_DIR}" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../../.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
while IFS=$'\t' read -r name args; do
  [[ -z "$name" || "$name" == \#* ]] && continue
  out="$work/$name"; mkdir -p "$out"
  cmd=${args//@OUT/$out}; cmd=${cmd//@SRC/$src}
  step=$(find "$out" -maxdepth 1 -name "stdout.*.txt" | wc -l)
  (cd "$work" && eval "\"$build/odocal\" $cmd") > "$out/stdout.$step.txt"
done < "$here/commands.txt"
# Text files are kept whole and compared number by number; files over 64 kB (telemetry,
# trajectories, HTML) keep only the SHA-256 of their normalised text, in NAME/digests.txt.
for d in "$work"/*/; do
  name=$(basename "$d"); rm -rf "${here:?}/$name"; mkdir -p "$here/$name"
  # record.json is when and where a run was (time, host, folder): its numbers are report.json's.
  (cd "$d" && find . -type f \( -name '*.json' -o -name '*.yaml' -o -name '*.csv' -o -name '*.txt' -o -name '*.html' \) ! -name record.json | sort |
     while IFS= read -r f; do
       f=${f#./}
       text=$(sed -e "s#${d%/}#@OUT#g" -e "s#$src#@SRC#g" "$f"; echo x)
       if (( $(stat -c %s "$f") > 65536 )); then
         printf '%s  %s\n' "$(printf '%s' "${text%x}" | sha256sum | cut -d' ' -f1)" "$f" >> "$here/$name/digests.txt"
       else
         mkdir -p "$here/$name/$(dirname "$f")"; printf '%s' "${text%x}" > "$here/$name/$f"
       fi
     done)
done
