#!/usr/bin/env bash
# Configures and builds URSLink into ${URS_BUILD_DIR:-build} with Ninja. Used by demo.sh and test.sh.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${URS_BUILD_DIR:-$root/build}
jobs=${URS_JOBS:-$(nproc)}
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=${URS_BUILD_TYPE:-RelWithDebInfo} >/dev/null
cmake --build "$build" -j "$jobs"
