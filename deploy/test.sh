#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test (unit, integration, e2e, bench smoke).
# Usage: deploy/test.sh [ctest arguments...]   e.g. deploy/test.sh -L unit
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/deploy/install-deps.sh"
"$root/deploy/build.sh"
build=${URS_BUILD_DIR:-$root/build}
cd "$build"
ctest --output-on-failure --timeout 300 -j "${URS_TEST_JOBS:-2}" "$@"
