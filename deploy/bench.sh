#!/usr/bin/env bash
# Installs what is missing, builds, runs every benchmark on loopback and writes the report:
# docs/performance.md (Markdown) and build/bench.json. Takes a few minutes on 2 cores.
# Usage: deploy/bench.sh [--quick]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/deploy/install-deps.sh"
"$root/deploy/build.sh"
build=${URS_BUILD_DIR:-$root/build}
table=$(mktemp)
"$build/tests/bench/urs-bench" "$@" --json "$build/bench.json" --markdown "$table" 2>"$build/bench.log"
{
  cat "$root/tests/bench/report-header.md"
  echo
  echo "Measured $(date -u +%Y-%m-%d) on $(nproc) cores, $(uname -sr), by \`deploy/bench.sh${*:+ $*}\`."
  echo
  cat "$table"
  echo
  cat "$root/tests/bench/report-notes.md"
} > "$root/docs/performance.md"
rm -f "$table"
cat "$root/docs/performance.md"
