#!/usr/bin/env bash
# scripts/format-check.sh [BASE]
#
# Do the C and C++ lines changed since BASE (a revision; default: main) follow
# .clang-format? Only the changed lines of the files `git diff --name-only BASE`
# names (committed or not) are checked, through git clang-format: the tree
# older than .clang-format is not reformatted, new code follows it.
# Exit 0: they do (or nothing changed); 1: they do not, and the diff that
# would fix them is printed (apply it with `git clang-format BASE`); 2: bad
# input or no clang-format (CLANG_FORMAT names another binary).
set -euo pipefail
cd "$(dirname "$0")/.."
base="${1:-main}"
clang_format="${CLANG_FORMAT:-$(command -v clang-format || true)}"
if [ -z "$clang_format" ]; then
  echo "format-check: clang-format not found (install it, or set CLANG_FORMAT)" >&2
  exit 2
fi
if ! git rev-parse --verify --quiet "${base}^{commit}" >/dev/null; then
  echo "format-check: ${base}: not a revision" >&2
  exit 2
fi
mapfile -t files < <(git diff --name-only --diff-filter=ACMR "$base" -- '*.c' '*.cc' '*.cpp' '*.h' '*.hpp')
if [ "${#files[@]}" -eq 0 ]; then
  echo "format-check: no C or C++ file changed since ${base}"
  exit 0
fi
diff="$(git clang-format --binary "$clang_format" --diff "$base" -- "${files[@]}")"
case "$diff" in
  "" | "no modified files to format" | "clang-format did not modify any files")
    echo "format-check: the lines changed since ${base} in ${#files[@]} files follow .clang-format"
    exit 0
    ;;
esac
printf '%s\n' "$diff"
echo "format-check: the lines above do not follow .clang-format; fix them with: git clang-format ${base}" >&2
exit 1
