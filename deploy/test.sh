#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test (unit, integration, e2e, bench smoke).
# Usage: deploy/test.sh [ctest arguments...]   e.g. deploy/test.sh -L unit
set -euo pipefail
source "$(dirname "$0")/prepare.sh"
install_and_build
cd "$build"
ctest --output-on-failure --timeout 300 -j "${URS_TEST_JOBS:-2}" "$@"
