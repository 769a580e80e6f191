#!/usr/bin/env bash
# Measures a cold build: configures a fresh build folder, builds everything without ccache, and
# prints where the time went (CPU seconds per file, per target and per kind of step).
#   deploy/build-time.sh [cmake arguments...]     e.g. deploy/build-time.sh -DURS_PCH=OFF
# Environment: URS_BUILD_TIME_DIR (default build-time/, removed first), URS_JOBS (default nproc),
#   URS_BUILD_TIME_TOP (files listed, default 25).
# Each compile and link runs under cmake/cpu_time_launcher.sh, which records its user+sys CPU
# time: the sum barely depends on what else the machine runs, unlike wall time, which is printed
# too (with the load average, to judge it). Steps that are neither (omniidl, protoc, fastddsgen)
# are counted by their wall time in .ninja_log. The report is also written to <folder>/build-time.txt.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${URS_BUILD_TIME_DIR:-$root/build-time}
jobs=${URS_JOBS:-$(nproc)}
rm -rf "$build"
mkdir -p "$build"
export URS_CPU_TIMES=$build/cpu-times.txt
launcher=$root/cmake/cpu_time_launcher.sh
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
t0=$(date +%s.%N)
env -u CMAKE_CXX_COMPILER_LAUNCHER -u CMAKE_C_COMPILER_LAUNCHER \
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=${URS_BUILD_TYPE:-RelWithDebInfo} \
  -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher" -DCMAKE_C_COMPILER_LAUNCHER="$launcher" \
  -DCMAKE_CXX_LINKER_LAUNCHER="$launcher" -DCMAKE_C_LINKER_LAUNCHER="$launcher" "$@" >"$build/configure.log"
t1=$(date +%s.%N)
build_status=0
cmake --build "$build" -j "$jobs" -- -k 0 >"$build/build.log" || build_status=$?
t2=$(date +%s.%N)
load_after=$(cut -d' ' -f1-3 /proc/loadavg)
python3 - "$build" "$t0" "$t1" "$t2" "$jobs" "$load_before" "$load_after" "${URS_BUILD_TIME_TOP:-25}" "$*" <<'PY' |
import collections, os, re, sys
build, t0, t1, t2, jobs, load_before, load_after, top, args = sys.argv[1:]
t0, t1, t2, top = float(t0), float(t1), float(t2), int(top)
cpu = {}
for line in open(os.path.join(build, "cpu-times.txt")):
    seconds, output = line.split(" ", 1)
    output = os.path.relpath(os.path.join(build, output.strip()), build)
    cpu[output] = cpu.get(output, 0.0) + float(seconds)
# .ninja_log: start and end (ms) of every step; a step with several outputs is listed once per output.
other = {}
for line in open(os.path.join(build, ".ninja_log")):
    if line.startswith("#"):
        continue
    start, end, _, output, command_hash = line.split("\t")
    if output not in cpu and not output.endswith((".o", ".so", ".a")) and "/" in output:
        other[command_hash] = (output, (int(end) - int(start)) / 1000.0)
def kind(path):
    if not path.endswith(".o"):
        return "link"
    if re.search(r"\.(cc|cxx)\.o$", path) or "unity_" in path and "/idl/" in path:
        return "compile generated code"
    if path.startswith("tests/"):
        return "compile tests"
    return "compile product code"
def target(path):
    match = re.search(r"CMakeFiles/([^/]+)\.dir/", path)
    return match.group(1) if match else os.path.basename(path)
kinds, targets = collections.Counter(), collections.Counter()
for path, seconds in cpu.items():
    kinds[kind(path)] += seconds
    targets[target(path)] += seconds
code_generators = sum(seconds for _, seconds in other.values())
total = sum(cpu.values())
compile_total = total - kinds["link"]
print(f"# Cold build{' (' + args + ')' if args else ''}: {len(cpu)} compile and link steps, -j{jobs}")
print(f"configure (wall)        {t1 - t0:8.1f} s")
print(f"build (wall)            {t2 - t1:8.1f} s   load average before {load_before}, after {load_after}")
print(f"compile (CPU)           {compile_total:8.1f} s   = {compile_total / 60:.1f} min, /{jobs} = {compile_total / 60 / int(jobs):.1f} min")
for name in ("compile product code", "compile tests", "compile generated code", "link"):
    print(f"  {name:22}{kinds[name]:8.1f} s")
print(f"code generators (wall)  {code_generators:8.1f} s   omniidl, protoc, fastddsgen, ...")
print(f"all steps (CPU)         {total + code_generators:8.1f} s")
failed = sum(1 for line in open(os.path.join(build, "build.log")) if line.startswith("FAILED: "))
if failed:
    print(f"FAILED steps: {failed} (build.log): the figures above lack them and what depends on them")
print(f"\n## The {top} costliest steps (CPU s)")
for path, seconds in sorted(cpu.items(), key=lambda item: -item[1])[:top]:
    print(f"{seconds:7.1f}  {path}")
print(f"\n## The {top} costliest targets (CPU s, compile and link)")
for name, seconds in targets.most_common(top):
    print(f"{seconds:7.1f}  {name}")
PY
  tee "$build/build-time.txt"
exit "$build_status"
