#!/usr/bin/env bash
# The peak resident memory (VmHWM) of every URSLink container's process while COMMAND runs, per
# compose service: the figures behind the Kubernetes requests and limits of deploy/services/services.yaml
# (docs/deployment.md, "Resources"). Samples every 2 s the containers of the images
# urslink/*:${URS_IMAGE_TAG:-dev} (their main process and its children), and prints, when COMMAND
# ends, the largest peak seen per service, in MiB.
#   deploy/services/measure-memory.sh -- tests/e2e/containers/run.sh    (the demo's load and faults)
set -uo pipefail
[[ "${1:-}" == "--" ]] && shift
(($#)) || { echo "usage: measure-memory.sh -- COMMAND..." >&2; exit 2; }
tag=${URS_IMAGE_TAG:-dev}
peaks=$(mktemp)
sample() {
  docker ps --format '{{.ID}} {{.Image}} {{.Label "com.docker.compose.service"}}' 2>/dev/null |
    while read -r id image service; do
      [[ $image == urslink/*:"$tag" && -n $service ]] || continue
      pid=$(docker inspect -f "{{.State.Pid}}" "$id" 2>/dev/null) || continue
      [[ $pid =~ ^[1-9][0-9]*$ ]] || continue   # not running (pid 0)
      for p in $pid $(pgrep -P "$pid" 2>/dev/null); do
        kb=$(awk '/^VmHWM:/ {print $2}' "/proc/$p/status" 2>/dev/null)
        [[ -n $kb ]] && echo "$service $(tr '\0' ' ' <"/proc/$p/cmdline" 2>/dev/null | awk '{print $1}' | xargs -r basename) $kb"
      done
    done >>"$peaks"
}
"$@" &
command_pid=$!
while kill -0 "$command_pid" 2>/dev/null; do
  sample
  sleep 2
done
wait "$command_pid"
status=$?
echo "peak RSS (VmHWM) per service and program, MiB, while: $*"
sort -k1,2 -k3,3n "$peaks" | awk '{peak[$1 " " $2] = ($3 > peak[$1 " " $2] ? $3 : peak[$1 " " $2])}
  END {for (k in peak) printf "%-28s %7.1f\n", k, peak[k] / 1024}' | sort
rm -f "$peaks"
exit "$status"
