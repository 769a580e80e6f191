# Sourced by the deploy scripts (after `set -euo pipefail`): sets root, the source tree, and build,
# the build folder (${URS_BUILD_DIR:-$root/build}, where deploy/build.sh builds), and defines
# install_and_build.
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${URS_BUILD_DIR:-$root/build}

# install_and_build [SKIP]: installs what is missing (deploy/install-deps.sh) and builds
# (deploy/build.sh), unless SKIP is non-empty (a script's *_NO_BUILD: use the binaries already built).
install_and_build() {
  [[ -n "${1:-}" ]] && return 0
  "$root/deploy/install-deps.sh"
  "$root/deploy/build.sh"
}
