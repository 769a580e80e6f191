#!/usr/bin/env bash
# package_example: installs the build into <build>/package-test/prefix, checks that the installed
# programs load the package's libraries from the prefix (RUNPATH $ORIGIN/../lib) and not from the
# build tree, builds examples/cpp/minimal against the prefix with find_package(urslink), hosts its
# Greeter agent on the installed urs-camus-server and calls it with the installed urs: a greeting,
# the declared exception, and the count; builds examples/cpp/plugin the same way and calls its
# agent hosted by the installed urs-sam (urs, the example's C++ client) and urs-rtc-manager (urs rtc
# call); imports the installed Python SDK, which loads an IDL file.
# As root, also checks that the installed urs-bridge loads IDL at run time with the installed
# omniidl back-end while the sources' one is hidden.
set -uo pipefail
root=$1
build=$2
work=$build/package-test
prefix=$work/prefix
test_name=package_example
source "$(dirname "$0")/../../support/process_test.sh"

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

# The plug-in example (examples/cpp/plugin), built against the prefix only: the installed urs-sam
# loads it by name from URS_PLUGIN_PATH; urs and the example's C++ client call its agent.
cmake -S "$root/examples/cpp/plugin" -B "$work/plugin" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" \
  >"$work/plugin-configure.log" 2>&1 || fail "configuring examples/cpp/plugin failed"
cmake --build "$work/plugin" >"$work/plugin-build.log" 2>&1 || fail "building examples/cpp/plugin failed"
printf 'plugins: [calculator_plugin]\nagents:\n  - {name: calc, type: calculator, params: {label: packaged}}\n' \
  >"$work/sam.yaml"
URS_PLUGIN_PATH="$work/plugin" "$prefix/bin/urs-sam" --space example --server "$URS_SERVER" --config "$work/sam.yaml" \
  >"$work/sam.log" 2>&1 &
pids+=($!)
calc_registered() { "$prefix/bin/urs" ls calc 2>/dev/null | grep -q '^calc .*PluginExample.Calculator'; }
wait_for "the plug-in's calc was not registered" calc_registered
reply=$("$prefix/bin/urs" call calc divide '{"dividend":1,"divisor":8}' 2>>"$work/call.log") || fail "calc divide failed"
[[ "$reply" == '{"result":0.125}' ]] || fail "calc divide answered '$reply'"
client=$("$work/plugin/calculator-client" --server "$URS_SERVER" --service calc 10 4 2>"$work/client.log") ||
  fail "calculator-client failed"
[[ "$client" == $'2.5\n2' ]] || fail "calculator-client printed '$client' (expected 2.5 and 2 calls)"
refusal=$("$work/plugin/calculator-client" --server "$URS_SERVER" --service calc 3 0 2>&1)
rc=$?
[[ $rc -eq 1 && "$refusal" == *'DivisionByZero (dividend 3)'* ]] || fail "calculator-client 3 0: exit $rc, '$refusal'"
# The same library as an RT-Component in the installed urs-rtc-manager, called with urs rtc call.
if omninames=$(command -v omniNames); then
  start_omninames "$omninames" "$work"
  printf 'plugins: [%s]\ncomponents: [{type: Calculator}]\n' "$work/plugin/libcalculator_plugin.so" >"$work/rtc.yaml"
  "$prefix/bin/urs-rtc-manager" --space example --naming "$URS_NAMING" --host pkg --config "$work/rtc.yaml" --ready-file "$work/rtc.ready" \
    >"$work/rtc-manager.log" 2>&1 &
  pids+=($!)
  wait_for "the installed urs-rtc-manager did not bind Calculator0" grep -qsx pkg.host_cxt/Calculator0.rtc "$work/rtc.ready"
  reply=$("$prefix/bin/urs" rtc call pkg.host_cxt/Calculator0.rtc:calculator divide '{"dividend":3,"divisor":2}' \
    --idl "$root/examples/cpp/plugin/idl/Calculator.idl" 2>&1) || fail "urs rtc call divide failed: $reply"
  [[ "$reply" == '{"result":1.5}' ]] || fail "urs rtc call divide answered '$reply'"
else
  echo "package_example: no omniNames: the plug-in in urs-rtc-manager not checked"
fi

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
echo "package_example: installed, examples built against $prefix, greeter and the calculator plug-in called"
