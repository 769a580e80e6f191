#!/usr/bin/env bash
# Fills the image build context from the install tree of the host build in ${URS_BUILD_DIR:-build}:
#   cmake --install <build> --prefix <context>/opt/urslink --strip
# gives the programs, the libraries (RUNPATH $ORIGIN/../lib), the IDL files and the omniidl Planet
# back-end (run-time IDL loading), example configurations, task files, the Fast DDS profile and the gateway's dashboard;
# the entry-point scripts are added to bin/. Headers and the CMake package, which no image uses,
# are left out. Nothing is compiled in an image.
#   deploy/images/stage.sh [CONTEXT_DIR]     (default ${URS_IMAGE_CONTEXT:-$URS_BUILD_DIR/image-context})
# URS_STAGE_NOSTRIP=1 keeps the debug information.
# Also checks that every shared library the staged programs and libraries link comes from the
# package's own lib/ or from a package of runtime-packages.txt (or the base image), so an image
# never misses a library at run time.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${URS_BUILD_DIR:-$root/build}
[[ "$build" = /* ]] || build=$root/$build
ctx=${1:-${URS_IMAGE_CONTEXT:-$build/image-context}}
[[ "$ctx" = /* ]] || ctx=$PWD/$ctx

[[ -f "$build/cmake_install.cmake" ]] || {
  echo "stage: $build is not a configured build: build first (URS_BUILD_DIR=$build deploy/build.sh)" >&2
  exit 1
}

rm -rf "$ctx"
prefix=$ctx/opt/urslink
strip=(--strip)
[[ "${URS_STAGE_NOSTRIP:-0}" == 1 ]] && strip=()
if ! log=$(cmake --install "$build" --prefix "$prefix" "${strip[@]}" 2>&1); then
  echo "stage: cmake --install $build failed (is the build complete?):" >&2
  echo "$log" | tail -20 >&2
  exit 1
fi
rm -rf "$prefix/include" "$prefix/lib/cmake" "$prefix/share/doc"
install -m 755 "$here/bin/urs-entrypoint" "$here/bin/urs-health" "$prefix/bin/"
install -m 644 "$here/runtime-packages.txt" "$ctx/runtime-packages.txt"

# Every NEEDED library must be the package's own or come from a listed package or the base image.
base_packages=" libc6 libgcc-s1 libstdc++6 zlib1g "
listed=" $(sed 's/#.*//' "$here/runtime-packages.txt" | tr -s ' \n' ' ') "
missing=()
programs=()
own_lib=$(cd "$prefix/lib" && pwd -P)
declare -A owner  # library path -> Debian package (dpkg -S is slow)
for file in "$prefix"/bin/* "$prefix"/lib/*.so*; do
  [[ -L "$file" ]] && continue
  readelf -h "$file" >/dev/null 2>&1 || continue  # the entry-point scripts
  [[ "$file" == "$prefix"/bin/* ]] && programs+=("$(basename "$file")")
  name=${file#"$prefix"/}
  resolved=$(ldd "$file")
  while read -r lib; do
    [[ "$lib" == ld-linux-* ]] && continue  # the dynamic loader, from libc6
    path=$(awk -v so="$lib" '$1 == so {print $3; exit}' <<<"$resolved")
    [[ -n "$path" && "$path" != "not" ]] || { missing+=("$name: $lib not found"); continue; }
    [[ "$(cd "$(dirname "$path")" && pwd -P)" == "$own_lib" ]] && continue  # the package's own
    if [[ -z "${owner[$path]+set}" ]]; then
      pkg=$(dpkg -S "$path" 2>/dev/null || dpkg -S "$(readlink -f "$path")" 2>/dev/null || true)
      owner[$path]=${pkg%%:*}
    fi
    pkg=${owner[$path]}
    [[ -n "$pkg" ]] || { missing+=("$name: $lib ($path) belongs to no Debian package"); continue; }
    [[ "$listed$base_packages" == *" $pkg "* ]] || missing+=("$name: $lib is in package $pkg")
  done < <(readelf -d "$file" | awk '/NEEDED/ {gsub(/[\[\]]/, "", $5); print $5}')
done
if ((${#missing[@]})); then
  printf 'stage: add to deploy/images/runtime-packages.txt:\n' >&2
  printf '  %s\n' "${missing[@]}" >&2
  exit 1
fi
echo "stage: $ctx ready ($(du -sh "$ctx" | cut -f1); programs: ${programs[*]})"
