#!/usr/bin/env bash
# package_example: installs the build into <build>/package-test/prefix, checks that the installed
# programs load the package's libraries from the prefix (RUNPATH $ORIGIN/../lib) and not from the
# build tree, builds examples/cpp/minimal against the prefix with find_package(urslink), hosts its
# Greeter agent on the installed urs-camus-server and calls it with the installed urs: a greeting,
# the declared exception, and the count; imports the installed Python SDK, which loads an IDL file.
# As root, also checks that the installed urs-bridge loads IDL at run time with the installed
# omniidl back-end while the sources' one is hidden.
set -uo pipefail
root=$1
build=$2
work=$build/package-test
prefix=$work/prefix
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null; done
}
trap cleanup EXIT
fail() {
  echo "package_example: $*"
  for log in "$work"/*.log; do [[ -s "$log" ]] && { echo "---- $log"; tail -40 "$log"; }; done
  exit 1
}
# Polls a condition every 0.1 s for at most 30 s.
wait_for() {
  local what=$1
  shift
  for _ in $(seq 300); do "$@" && return 0; sleep 0.1; done
  fail "$what within 30 s"
}

rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$prefix" >"$work/install.log" 2>&1 || fail "cmake --install $build failed"
for program in urs-camus-server urs-sam urs-rtc-manager urs urs-bridge urs-lab; do
  [[ -x "$prefix/bin/$program" ]] || fail "bin/$program is not installed"
done
[[ -f "$prefix/lib/cmake/urslink/urslinkConfig.cmake" ]] || fail "no lib/cmake/urslink/urslinkConfig.cmake"
[[ -f "$prefix/share/urslink/idl/omniidl_planet/planet_proto.py" ]] || fail "no omniidl back-end in share/urslink/idl"
# The Python SDK from the prefix: it finds the installed omniidl back-end by itself.
PYTHONPATH="$prefix/share/urslink/python" env -u URS_OMNIIDL_BACKEND_DIR /usr/bin/python3 -c \
  'import sys, urslink; print(urslink.Interface.from_idl(sys.argv[1]).name)' "$root/examples/python/Thermostat.idl" \
  >"$work/python-sdk.log" 2>&1 && grep -qx Demo.Thermostat "$work/python-sdk.log" ||
  fail "the installed Python SDK (share/urslink/python) cannot load an IDL file: $(cat "$work/python-sdk.log")"

# Every URSLink library an installed program or library needs resolves inside the prefix.
for file in "$prefix"/bin/* "$prefix"/lib/liburslink_*.so.*.*; do
  [[ -L "$file" ]] && continue
  runpath=$(readelf -d "$file" | sed -n 's/.*(RUNPATH).*\[\(.*\)\]/\1/p')
  [[ "$runpath" == '$ORIGIN/../lib' ]] || fail "$file: RUNPATH is '$runpath', not \$ORIGIN/../lib"
  while read -r lib _ path _; do
    [[ -e "$path" && "$(cd "$(dirname "$path")" && pwd -P)" == "$(cd "$prefix/lib" && pwd -P)" ]] ||
      fail "$file: $lib resolves to '$path', not to $prefix/lib"
  done < <(ldd "$file" | grep 'liburslink_')
done

# The example, configured and built against the installed package only.
cmake -S "$root/examples/cpp/minimal" -B "$work/example" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" \
  >"$work/example-configure.log" 2>&1 || fail "configuring examples/cpp/minimal failed"
found=$(sed -n 's/^urslink_DIR:PATH=//p' "$work/example/CMakeCache.txt")
[[ "$found" == "$prefix/lib/cmake/urslink" ]] || fail "find_package(urslink) found '$found', not the installed package"
cmake --build "$work/example" >"$work/example-build.log" 2>&1 || fail "building examples/cpp/minimal failed"

# The example's agent on the installed CAMUS server, called with the installed urs.
"$prefix/bin/urs-camus-server" --space example --listen 127.0.0.1:0 --port-file "$work/port" \
  >"$work/server.log" 2>&1 &
pids+=($!)
wait_for "the server wrote no port file" test -s "$work/port"
export URS_SERVER=127.0.0.1:$(cat "$work/port")
"$work/example/greeter-agent" --space example --server "$URS_SERVER" >"$work/agent.log" 2>&1 &
pids+=($!)
registered() { "$prefix/bin/urs" ls greeter 2>/dev/null | grep -q '^greeter .*Example.Greeter'; }
wait_for "greeter was not registered" registered

reply=$("$prefix/bin/urs" call greeter greet '{"name":"URSLink"}' 2>"$work/call.log") || fail "greet failed"
[[ "$reply" == '{"result":"Hello, URSLink"}' ]] || fail "greet answered '$reply'"
refusal=$("$prefix/bin/urs" call greeter greet '{"name":""}' 2>&1)
rc=$?
[[ $rc -eq 1 && "$refusal" == *USER_EXCEPTION* && "$refusal" == *'give a name to greet'* ]] ||
  fail "greet with an empty name: exit $rc, '$refusal' (expected the EmptyName exception)"
count=$("$prefix/bin/urs" call greeter count 2>>"$work/call.log") || fail "count failed"
[[ "$count" == '{"result":1}' ]] || fail "count answered '$count'"
# Run-time IDL loading by an installed program finds the installed omniidl back-end: the sources'
# back-end (the build tree's default) is hidden by a bind mount in a private mount namespace.
if [[ $(id -u) -eq 0 ]] && unshare -m true 2>/dev/null; then
  printf 'name: package-bridge\nidl: [%s]\n' "$root/examples/cpp/minimal/idl/Greeter.idl" >"$work/bridge.yaml"
  mkdir -p "$work/empty"
  env -u URS_OMNIIDL_BACKEND_DIR unshare -m sh -c 'mount --bind "$1" "$2" && exec "$3" --space example --server "$4" --config "$5"' \
    sh "$work/empty" "$root/idl/omniidl_planet" "$prefix/bin/urs-bridge" "$URS_SERVER" "$work/bridge.yaml" \
    >"$work/bridge.log" 2>&1 &
  bridge=$!
  pids+=($bridge)
  loaded() {
    grep -q 'interface Example.Greeter loaded' "$work/bridge.log" && return 0
    kill -0 "$bridge" 2>/dev/null || fail "the installed urs-bridge could not load Greeter.idl"
    return 1
  }
  wait_for "the installed urs-bridge did not load Greeter.idl" loaded
else
  echo "package_example: not root: run-time IDL loading from the install tree not checked"
fi
echo "package_example: installed, example built against $prefix, greeter called through the installed server and urs"
