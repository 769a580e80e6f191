#!/usr/bin/env bash
# deploy/lint.sh against a small git repository made here, with the tree's .clang-format and
# .clang-tidy and the real clang-format and clang-tidy: a clean tree passes; a layout violation
# fails, names the file and the fix, and --fix repairs it; a name against the scheme on a changed
# line of a source or a header fails; one in a file or on a line that did not change is not
# reported, unless --all or --whole-files.
#   lint_test.sh <source tree>
set -euo pipefail
tree=$1
lint=$tree/deploy/lint.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
repo=$work/repo
failures=0
check() {  # check <description> <expected exit code> <expected text or ""> -- <command...>
  local what=$1 expected=$2 text=$3
  shift 4
  local out rc=0
  out=$("$@" 2>&1) || rc=$?
  if [[ $rc -ne $expected ]]; then
    echo "FAIL: $what: exit $rc, expected $expected"; echo "$out" | sed 's/^/    /'; failures=$((failures + 1)); return
  fi
  if [[ -n "$text" ]] && ! grep -qF -- "$text" <<<"$out"; then
    echo "FAIL: $what: no '$text' in:"; echo "$out" | sed 's/^/    /'; failures=$((failures + 1)); return
  fi
  echo "ok: $what"
}
lint() { URS_LINT_ROOT=$repo URS_BUILD_DIR=$repo/build URS_JOBS=2 "$lint" "$@"; }
# compile_commands.json: every .cpp of the repository, as CMake would list them.
database() {
  (cd "$repo" && git ls-files --cached --others --exclude-standard -- '*.cpp') | python3 -c '
import json, sys
repo = sys.argv[1]
print(json.dumps([{"directory": repo + "/build", "file": repo + "/" + f.strip(),
                   "command": "c++ -std=c++17 -Wall -Werror -I" + repo + "/services -c " + repo + "/" + f.strip()}
                  for f in sys.stdin]))' "$repo" >"$repo/build/compile_commands.json"
}

mkdir -p "$repo/services/demo" "$repo/build"
cp "$tree/.clang-format" "$tree/.clang-tidy" "$repo/"
printf 'build/\n' >"$repo/.gitignore"
# good.hpp, with its further declarations if any (one a line).
write_header() {
  {
    printf '#pragma once\n\nnamespace demo {\n\n'
    printf 'class Counter {\n public:\n  int next() { return ++count_; }\n\n private:\n  int count_ = 0;\n};\n'
    for declaration in "$@"; do printf '\n%s\n' "$declaration"; done
    printf '\n}  // namespace demo\n'
  } >"$repo/services/demo/good.hpp"
}
write_header
cat >"$repo/services/demo/good.cpp" <<'CPP'
#include "demo/good.hpp"

namespace demo {

int count_twice() {
  Counter counter;
  counter.next();
  return counter.next();
}

}  // namespace demo
CPP
# A name against the scheme that is already on main: reported by --all only.
cat >"$repo/services/demo/old.cpp" <<'CPP'
namespace demo {

int OldName() { return 1; }

}  // namespace demo
CPP
git -C "$repo" init -q -b main
git -C "$repo" -c user.name=lint -c user.email=lint@localhost add -A
git -C "$repo" -c user.name=lint -c user.email=lint@localhost commit -q -m base
git -C "$repo" checkout -q -b topic
database

check "a clean tree passes" 0 "lint: names: no C++ file changed since the merge base" -- lint
check "--all finds the old name" 1 "OldName" -- lint --names --all

cat >"$repo/services/demo/ugly.cpp" <<'CPP'
namespace demo {
int  sum( int a,int b ){return a+b;}
}  // namespace demo
CPP
database
check "a layout violation fails" 1 "services/demo/ugly.cpp (1 line(s), first at line 2)" -- lint --format
check "it says how to fix it" 1 "fix with: clang-format -i services/demo/ugly.cpp" -- lint --format
check "--fix repairs it" 0 "lint: layout:" -- lint --format --fix
check "the repaired file's names pass" 0 "lint: names: as .clang-tidy says" -- lint --names

cat >"$repo/services/demo/bad.cpp" <<'CPP'
namespace demo {

int BadName() { return 2; }

}  // namespace demo
CPP
database
check "a function name against the scheme fails" 1 "invalid case style for function 'BadName'" -- lint --names
check "the unchanged file's name is not reported" 1 "" -- bash -c "! URS_LINT_ROOT=$repo URS_BUILD_DIR=$repo/build $lint --names 2>&1 | grep -q OldName && exit 1"
git -C "$repo" -c user.name=lint -c user.email=lint@localhost add -A
git -C "$repo" -c user.name=lint -c user.email=lint@localhost commit -q -m bad
check "committed on the branch, it still fails" 1 "BadName" -- lint --names
check "--base names the comparison" 0 "" -- lint --names --base HEAD

git -C "$repo" rm -q services/demo/bad.cpp
git -C "$repo" -c user.name=lint -c user.email=lint@localhost commit -q -m "bad gone"
write_header "struct wrong_struct {};"
database
check "a changed header is checked through a source including it" 1 "invalid case style for struct 'wrong_struct'" -- lint --names

# A file with an old name that changes elsewhere: only its changed lines are reported.
git -C "$repo" checkout -q -- services/demo/good.hpp
append_function() { printf '\nnamespace demo {\n\nint %s() { return 3; }\n\n}  // namespace demo\n' "$1" >>"$repo/$2"; }
append_function new_name services/demo/old.cpp
check "an old name on an unchanged line of a changed file passes" 0 "lint: names: as .clang-tidy says" -- lint --names
check "--whole-files reports it" 1 "OldName" -- lint --names --whole-files
append_function AnotherBadName services/demo/old.cpp
check "a bad name on a changed line of that file fails" 1 "AnotherBadName" -- lint --names
git -C "$repo" checkout -q -- services/demo/old.cpp
# The old name's line re-spaced (as a formatting commit aligns comments) while the file changes elsewhere:
# that line's change is only white space, so its name is not reported.
sed -i "s/^int OldName() { return 1; }$/int  OldName()  {  return 1;  }/" "$repo/services/demo/old.cpp"
append_function another_new_name services/demo/old.cpp
check "an old name on a line whose change is only layout passes" 0 "lint: names: as .clang-tidy says" -- lint --names
git -C "$repo" checkout -q -- services/demo/old.cpp

# On main itself (a CI run on a fresh clone): the last first-parent commits count as changed.
git -C "$repo" checkout -q main
check "on main, the last commits count as changed" 1 "OldName" -- lint --names
check "URS_LINT_COMMITS=0 checks nothing on main" 0 "no C++ file changed by the last 0" -- env URS_LINT_COMMITS=0 URS_LINT_ROOT=$repo URS_BUILD_DIR=$repo/build "$lint" --names

if ((failures)); then
  echo "$failures check(s) failed"
  exit 1
fi
echo "every check passed"
