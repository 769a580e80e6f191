#!/usr/bin/env bash
# Fills the image build context with what the URSLink images run: the host-built binaries from
# ${URS_BUILD_DIR:-build} (stripped of debug info), the IDL files and the omniidl Planet back-end
# (run-time IDL loading), example configurations, task files, the Fast DDS profile, the gateway's
# dashboard and the entry-point scripts. Nothing is compiled in an image.
#   deploy/images/stage.sh [CONTEXT_DIR]     (default ${URS_IMAGE_CONTEXT:-$URS_BUILD_DIR/image-context})
# Also checks that every shared library the binaries link comes from a package of
# runtime-packages.txt (or the base image), so an image never misses a library at run time.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${URS_BUILD_DIR:-$root/build}
[[ "$build" = /* ]] || build=$root/$build
ctx=${1:-${URS_IMAGE_CONTEXT:-$build/image-context}}

declare -A binaries=(
  [urs-camus-server]=services/camus-server/urs-camus-server
  [urs-sam]=services/sam/urs-sam
  [urs-rtc-manager]=services/rtc-manager/urs-rtc-manager
  [urs]=services/cli/urs
  [urs-bridge]=services/bridge/urs-bridge
  [urs-lab]=services/lab/urs-lab
  [urs-gateway]=services/gateway/urs-gateway
)

for name in "${!binaries[@]}"; do
  [[ -x "$build/${binaries[$name]}" ]] || {
    echo "stage: $build/${binaries[$name]} is missing: build first (URS_BUILD_DIR=$build deploy/build.sh)" >&2
    exit 1
  }
done

rm -rf "$ctx"
bin=$ctx/opt/urslink/bin
share=$ctx/opt/urslink/share/urslink
mkdir -p "$bin" "$share/idl" "$share/config" "$share/tasks"

strip_tool=$(command -v strip || true)
for name in "${!binaries[@]}"; do
  if [[ -n "$strip_tool" && "${URS_STAGE_NOSTRIP:-0}" != 1 ]]; then
    "$strip_tool" --strip-debug -o "$bin/$name" "$build/${binaries[$name]}"
  else
    cp "$build/${binaries[$name]}" "$bin/$name"
  fi
done
install -m 755 "$here/bin/urs-entrypoint" "$here/bin/urs-health" "$bin/"

# IDL: the interfaces, urs_options.proto and the omniidl back-end (URS_OMNIIDL_BACKEND_DIR).
(cd "$root/idl" && find . \( -name '*.idl' -o -name '*.proto' -o -path './omniidl_planet/*.py' \) -print0 |
  xargs -0 -I{} install -D -m 644 {} "$share/idl/{}")
install -m 644 "$root/services/sam/diagnostic.yaml" "$share/config/sam-diagnostic.yaml"
install -m 644 "$root/services/rtc-manager/example.yaml" "$share/config/rtc-example.yaml"
[[ -f "$root/services/bridge/example.yaml" ]] && install -m 644 "$root/services/bridge/example.yaml" "$share/config/bridge-example.yaml"
install -m 644 "$root"/services/camus-server/tasks/*.yaml "$share/tasks/"
install -m 644 "$root/compose/fastdds-udp.xml" "$share/fastdds-udp.xml"
install -m 644 "$here/runtime-packages.txt" "$ctx/runtime-packages.txt"
# urs-gateway's dashboard (static files; the program finds them in ../share/urslink/web).
mkdir -p "$share/web"
install -m 644 "$root"/services/gateway/web/* "$share/web/"

# Every NEEDED library must come from a listed package or the base image.
base_packages=" libc6 libgcc-s1 libstdc++6 zlib1g "
listed=" $(sed 's/#.*//' "$here/runtime-packages.txt" | tr -s ' \n' ' ') "
missing=()
for name in "${!binaries[@]}"; do
  while read -r lib path; do
    [[ -n "$path" && "$path" != "not" ]] || { missing+=("$name: $lib not found on this host"); continue; }
    pkg=$(dpkg -S "$path" 2>/dev/null || dpkg -S "$(readlink -f "$path")" 2>/dev/null || true)
    pkg=${pkg%%:*}
    [[ -n "$pkg" ]] || { missing+=("$name: $lib ($path) belongs to no Debian package"); continue; }
    [[ "$listed$base_packages" == *" $pkg "* ]] || missing+=("$name: $lib is in package $pkg")
  done < <(readelf -d "$build/${binaries[$name]}" | awk '/NEEDED/ {gsub(/[\[\]]/, "", $5); print $5}' |
           while read -r so; do
             echo "$so $(ldd "$build/${binaries[$name]}" | awk -v so="$so" '$1 == so {print $3; exit}')"
           done)
done
if ((${#missing[@]})); then
  printf 'stage: add to deploy/images/runtime-packages.txt:\n' >&2
  printf '  %s\n' "${missing[@]}" >&2
  exit 1
fi
echo "stage: $ctx ready ($(du -sh "$ctx" | cut -f1); binaries: ${!binaries[*]})"
