#!/usr/bin/env bash
# A compiler and linker launcher (CMAKE_<LANG>_COMPILER_LAUNCHER, CMAKE_<LANG>_LINKER_LAUNCHER) that
# runs the command and appends one line to $URS_CPU_TIMES: "<user+sys CPU seconds> <output file>".
# CPU time, unlike a step's wall time in .ninja_log, barely changes with what else runs on the
# machine. Used by deploy/build-time.sh; without URS_CPU_TIMES it only runs the command.
"$@"
rc=$?
if [[ -n "${URS_CPU_TIMES:-}" ]]; then
  output=unknown
  args=("$@")
  for ((i = 0; i < ${#args[@]} - 1; i++)); do
    if [[ "${args[i]}" == -o ]]; then output=${args[i + 1]}; fi
  done
  # The second line of `times` is the children's user and system time, e.g. "0m1.234s 0m0.056s".
  # (`times` runs in this shell: in a subshell it would see no children.)
  times >"$URS_CPU_TIMES.$$"
  read -r _ _ user sys < <(tr '\n' ' ' <"$URS_CPU_TIMES.$$")
  rm -f "$URS_CPU_TIMES.$$"
  awk -v u="$user" -v s="$sys" -v o="$output" 'function sec(t) { split(t, p, "m"); return p[1] * 60 + p[2] }
    BEGIN { printf "%.3f %s\n", sec(u) + sec(s), o }' >>"$URS_CPU_TIMES"
fi
exit $rc
