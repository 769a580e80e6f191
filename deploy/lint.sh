#!/usr/bin/env bash
# The lint step: the tree's layout (clang-format, .clang-format) and the names of what changed
# (clang-tidy's readability-identifier-naming, .clang-tidy). Exits 1 on any violation, saying how
# to fix it; 2 on a usage or set-up error. Run by .ci/run before the tests (CONTRIBUTING.md).
#   deploy/lint.sh                  both checks
#   deploy/lint.sh --format         only the layout: every C++ file, tracked or new (seconds; no build)
#   deploy/lint.sh --names          only the names of the changed C++ files (needs a configured,
#                                   built folder: compile_commands.json and the generated headers)
#   deploy/lint.sh --fix            rewrites the files whose layout differs (clang-format -i), then checks
#   deploy/lint.sh --names --whole-files   every name in the changed files, not only on changed lines
# Which files count as changed, for --names:
#   --base REV (or URS_LINT_BASE=REV)  those that differ between REV and the working tree
#   --all                              every C++ file of the tree
#   otherwise, on a branch other than main: those that differ from the merge base with main,
#   committed or not (untracked new files too); on main itself or a detached HEAD (a CI run on a
#   fresh clone of main): those changed by its last ${URS_LINT_COMMITS:-10} first-parent commits,
#   that is the last merges and commits that landed, and any uncommitted change.
# Reported are the names on the changed lines of those files (a new file: all its lines; a line
# whose change is only white space is not a changed one), so that a name the tree already had
# elsewhere in a file does not fail a change; --whole-files reports
# every name of a changed file (--all: of every file). A file whose change is only white space (a
# formatting commit) is not checked. A changed header is checked through one translation unit that
# includes it (ninja's dependency log, else any source that names it).
# Environment: URS_BUILD_DIR (default build/), URS_JOBS (default nproc), URS_LINT_ROOT (the tree
# to check, default the one holding this script; the lint's own test points it elsewhere).
set -euo pipefail
root=${URS_LINT_ROOT:-$(cd "$(dirname "$0")/.." && pwd)}
build=${URS_BUILD_DIR:-$root/build}
jobs=${URS_JOBS:-$(nproc)}
commits=${URS_LINT_COMMITS:-10}
base=${URS_LINT_BASE:-}
do_format=1 do_names=1 fix=0 all=0 whole_files=0
while (($#)); do
  case $1 in
    --format) do_names=0 ;;
    --names) do_format=0 ;;
    --fix) fix=1 ;;
    --all) all=1 ;;
    --whole-files) whole_files=1 ;;
    --base)
      [[ $# -ge 2 ]] || { echo "lint: --base needs a revision" >&2; exit 2; }
      base=$2
      shift
      ;;
    *) echo "lint: unknown argument '$1' (--format, --names, --fix, --all, --whole-files, --base REV)" >&2; exit 2 ;;
  esac
  shift
done
for tool in clang-format clang-tidy git; do
  command -v "$tool" >/dev/null || { echo "lint: $tool not found: run deploy/install-deps.sh" >&2; exit 2; }
done
cd "$root"
cpp_files=(':(glob)**/*.cpp' ':(glob)**/*.hpp' ':(glob)**/*.h' ':(glob)**/*.cc')
failed=0

if ((do_format)); then
  mapfile -t files < <(git ls-files --cached --others --exclude-standard -- "${cpp_files[@]}" |
                       while read -r file; do [[ -f "$file" ]] && echo "$file"; done)
  if ((fix)); then
    printf '%s\0' "${files[@]}" | xargs -0 -r clang-format -i
  fi
  # --dry-run prints every differing line as "<file>:<line>:<col>: error: code should be clang-formatted".
  report=$(printf '%s\0' "${files[@]}" | xargs -0 -r -n 50 -P "$jobs" clang-format --dry-run --Werror 2>&1 || true)
  mapfile -t bad < <(grep -o '^[^:]*:[0-9]*:[0-9]*: error: code should be clang-formatted' <<<"$report" |
                     cut -d: -f1 | sort -u)
  if ((${#bad[@]})); then
    failed=1
    echo "lint: ${#bad[@]} file(s) differ from .clang-format's layout:"
    for file in "${bad[@]}"; do
      lines=$(grep "^$file:[0-9]*:[0-9]*: error" <<<"$report" | cut -d: -f2 | sort -un)
      echo "  $file ($(wc -l <<<"$lines") line(s), first at line $(head -1 <<<"$lines"))"
    done
    echo "lint: fix with: clang-format -i ${bad[*]}"
    echo "lint:   (or deploy/lint.sh --fix for the whole tree; git clang-format for a commit's lines only)"
  elif grep -q 'error' <<<"$report"; then
    echo "lint: clang-format failed:" >&2
    echo "$report" >&2
    exit 2
  else
    echo "lint: layout: ${#files[@]} files as .clang-format says"
  fi
fi

if ((do_names)); then
  # The changed files, repository-relative.
  if ((all)); then
    mapfile -t changed < <(git ls-files --cached --others --exclude-standard -- "${cpp_files[@]}")
    what="in the tree"
  else
    if [[ -z "$base" ]]; then
      branch=$(git symbolic-ref --short -q HEAD || true)
      merge_base=$(git merge-base HEAD main 2>/dev/null || true)
      if [[ -n "$branch" && "$branch" != main && -n "$merge_base" ]]; then
        base=$merge_base
        what="changed since the merge base with main (${base:0:10})"
      else
        base=$(git rev-list --first-parent -n "$((commits + 1))" HEAD | tail -1)
        if [[ $(git rev-list --first-parent --count HEAD) -le $commits ]]; then
          base=$(git hash-object -t tree /dev/null)  # the empty tree: every file is new
        fi
        what="changed by the last $commits first-parent commits (since ${base:0:10})"
      fi
    else
      what="changed since $base"
    fi
    git rev-parse --verify -q "$base^{object}" >/dev/null || { echo "lint: unknown revision '$base'" >&2; exit 2; }
    mapfile -t differing < <({ git diff --name-only --diff-filter=d "$base" -- "${cpp_files[@]}"
                               git ls-files --others --exclude-standard -- "${cpp_files[@]}"; } | sort -u)
    # A file whose change is only layout (the same characters but for white space, as after a
    # formatting commit) cannot have changed a name: it is left out.
    changed=() layout_only=0
    for file in "${differing[@]}"; do
      if git cat-file -e "$base:$file" 2>/dev/null &&
        [[ "$(git cat-file -p "$base:$file" | tr -d '[:space:]' | md5sum)" == "$(tr -d '[:space:]' <"$file" | md5sum)" ]]; then
        layout_only=$((layout_only + 1))
      else
        changed+=("$file")
      fi
    done
    if ((layout_only)); then
      what="$what; $layout_only more changed only their layout"
    fi
  fi
  if ((${#changed[@]} == 0)); then
    echo "lint: names: no C++ file $what"
  else
    database=$build/compile_commands.json
    [[ -f "$database" ]] || { echo "lint: $database missing: configure and build first (deploy/build.sh)" >&2; exit 2; }
    # The translation units to run clang-tidy on: each changed source the build compiles, and for
    # each changed header one source that includes it. Without a precompiled header: clang cannot
    # read GCC's, and a source must include what it uses anyway.
    tidy_dir=$(mktemp -d)
    trap 'rm -rf "$tidy_dir"' EXIT
    deps=$tidy_dir/deps
    ninja -C "$build" -t deps >"$deps" 2>/dev/null || : >"$deps"
    diff_base=$base
    if ((all || whole_files)); then diff_base=""; fi
    URS_LINT_DIFF_BASE=$diff_base python3 - "$database" "$tidy_dir" "$root" "$deps" "${changed[@]}" <<'PY'
import json, os, re, shlex, sys
database, out_dir, root, deps_file, *changed = sys.argv[1:]
entries = json.load(open(database))
by_source = {}
for entry in entries:
    command = entry.get("command") or shlex.join(entry["arguments"])
    # CMake's precompiled header: "-include <dir>/cmake_pch.hxx" (GCC adds -Winvalid-pch).
    command = re.sub(r"\s-include\s+\S*cmake_pch\.hxx", "", command).replace(" -Winvalid-pch", "")
    entry = dict(entry, command=command)
    entry.pop("arguments", None)
    source = os.path.normpath(os.path.join(entry["directory"], entry["file"]))
    by_source[source] = entry
# ninja -t deps: "<object>: #deps N, ..." then one indented header per line.
build_dir = os.path.dirname(database)
includers, current = {}, None
for line in open(deps_file):
    if not line.startswith(" "):
        current = line.split(":")[0].strip()
    elif line.strip():
        includers.setdefault(os.path.normpath(os.path.join(build_dir, line.strip())), []).append(current)
outputs = {}
for source, entry in by_source.items():
    output = entry.get("output")
    if output:
        outputs[os.path.normpath(os.path.join(entry["directory"], output))] = source
units, unchecked = [], []
for path in changed:
    full = os.path.normpath(os.path.join(root, path))
    if full in by_source:
        units.append(full)
        continue
    candidates = []
    for obj in includers.get(full, []):
        source = outputs.get(os.path.normpath(os.path.join(build_dir, obj)))
        if source:
            candidates.append(source)
    if not candidates and path.endswith((".hpp", ".h")):
        name = os.path.basename(path)
        for source in sorted(by_source):
            if source.startswith(root + os.sep) and os.path.exists(source):
                if re.search(r'#include\s+"([^"]*/)?' + re.escape(name) + '"', open(source, errors="replace").read()):
                    candidates.append(source)
                    break
    if candidates:
        units.append(sorted(candidates)[0])
    else:
        unchecked.append(path)
units = sorted(set(units))
json.dump([by_source[unit] for unit in units], open(os.path.join(out_dir, "compile_commands.json"), "w"))
open(os.path.join(out_dir, "units"), "w").write("".join(unit + "\n" for unit in units))
open(os.path.join(out_dir, "unchecked"), "w").write("".join(path + "\n" for path in unchecked))
# What is reported: the changed lines of each changed file (git diff -U0 against the base, white
# space ignored: a line whose change is only its layout, as a formatting commit's, changed no
# name), or whole files (--whole-files, --all, and files new to git).
base = os.environ.get("URS_LINT_DIFF_BASE", "")
line_filter = []
if base:
    import subprocess
    diff = subprocess.run(["git", "diff", "-U0", "-w", "--no-color", "--no-ext-diff", base, "--", *changed],
                          cwd=root, check=True, capture_output=True, text=True).stdout
    ranges, current = {}, None
    for line in diff.splitlines():
        if line.startswith("+++ "):
            current = line[6:] if line.startswith("+++ b/") else None
        elif line.startswith("@@") and current:
            match = re.match(r"@@ -\S+ \+(\d+)(?:,(\d+))? @@", line)
            start, count = int(match.group(1)), int(match.group(2) or "1")
            if count:
                ranges.setdefault(current, []).append([start, start + count - 1])
    for path in changed:
        if path in ranges:
            line_filter.append({"name": path, "lines": ranges[path]})
        elif not subprocess.run(["git", "ls-files", "--error-unmatch", path], cwd=root,
                                capture_output=True).returncode == 0:
            line_filter.append({"name": path})  # new to git: every line
else:
    line_filter = [{"name": path} for path in changed]
json.dump(line_filter or [{"name": "none", "lines": [[1, 0]]}], open(os.path.join(out_dir, "line_filter"), "w"))
PY
    mapfile -t units <"$tidy_dir/units"
    mapfile -t unchecked <"$tidy_dir/unchecked"
    if ((${#unchecked[@]})); then
      echo "lint: names: not compiled by this build, not checked: ${unchecked[*]}"
    fi
    echo "lint: names: ${#changed[@]} C++ file(s) $what, through ${#units[@]} translation unit(s)"
    if ((${#units[@]})); then
      # -w: clang's warnings differ from GCC's (-Werror is in the commands); the check stays an error.
      if ! printf '%s\0' "${units[@]}" |
        xargs -0 -n 4 -P "$jobs" clang-tidy -p "$tidy_dir" --quiet --extra-arg=-w \
          --warnings-as-errors='readability-identifier-naming' --line-filter="$(cat "$tidy_dir/line_filter")" \
          >"$tidy_dir/report" 2>&1; then
        failed=1
        grep -v '^[0-9]* warnings\? generated\.$\|^Suppressed [0-9]* warnings\|^Use -header-filter\|^Error while processing' \
          "$tidy_dir/report" || true
        echo "lint: names differ from .clang-tidy's scheme (above); rename as it says (CONTRIBUTING.md, Conventions),"
        echo "lint:   or see them with: clang-tidy -p $build <file>"
      else
        echo "lint: names: as .clang-tidy says"
      fi
    fi
  fi
fi
exit "$failed"
