# Shared by the container e2e scripts (run.sh, tcp.sh; sourced after ../steps.sh): the compose
# command, the images, the project's health, a client in each space and the checks between the
# spaces. The sourcing script sets `root`, `build`, `project`, `compose_files` (its -f arguments)
# and `tmp` before it calls them.

# Docker and a compose tool, in compose_cmd: URS_COMPOSE, else `docker compose` when present, else
# docker-compose. Dies naming what is missing: the tests never skip.
find_compose() {
  command -v docker >/dev/null || die "docker is not installed (Debian: apt-get install docker.io); this test needs it"
  docker info >/dev/null 2>&1 || die "the docker daemon does not answer (is it running? may $(id -un) use it?)"
  if [[ -n "${URS_COMPOSE:-}" ]]; then
    read -r -a compose_cmd <<<"$URS_COMPOSE"
  elif docker compose version >/dev/null 2>&1; then
    compose_cmd=(docker compose)
  elif command -v docker-compose >/dev/null; then
    compose_cmd=(docker-compose)
  else
    die "neither 'docker compose' nor docker-compose is installed (Debian: apt-get install docker-compose)"
  fi
}

# A free host port (the dashboards', Prometheus'), below the kernel's ephemeral range: Docker binds
# it seconds after it was chosen, and a port of that range may meanwhile be taken by any
# connection of the tests running alongside.
free_port() {
  /usr/bin/python3 -c '
import random, socket
below = int(open("/proc/sys/net/ipv4/ip_local_port_range").read().split()[0])
while True:
    port = random.randrange(10000, below)
    with socket.socket() as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            continue
    print(port)
    break
'
}

# The credentials compose mounts as secrets (deploy/images/build.sh writes them too).
make_credentials() {
  "$root/compose/make-token.sh" >/dev/null
  "$root/compose/make-token.sh" "${URS_KR_OPERATOR_TOKEN_FILE:-$root/compose/config/kr-operator.token}" >/dev/null
  "$root/compose/make-token.sh" "${URS_JP_TOKEN_FILE:-$root/compose/config/jp.token}" >/dev/null
}

dc() { timeout "${DC_TIMEOUT:-180}" "${compose_cmd[@]}" -p "$project" "${compose_files[@]}" "$@"; }

# cli containers (profile `tools`): stdout only; stderr kept for failures
kr() { dc run --rm -T cli-kr "$@" 2>"$tmp/cli.err"; }
jp() { dc run --rm -T cli-jp "$@" 2>"$tmp/cli.err"; }

# The images of SERVICE...: deploy/images/build.sh (Docker's cache reuses what is unchanged), or,
# with URS_E2E_SKIP_IMAGE_BUILD=1, the urslink/*:${URS_IMAGE_TAG:-dev} images as they are.
images() {
  local s t=$SECONDS
  step "images"
  if [[ "${URS_E2E_SKIP_IMAGE_BUILD:-0}" == 1 ]]; then
    for s in "$@"; do
      docker image inspect "urslink/$s:${URS_IMAGE_TAG:-dev}" >/dev/null 2>&1 || fail "image urslink/$s:${URS_IMAGE_TAG:-dev} is missing"
    done
  else
    URS_BUILD_DIR=$build timeout 480 "$root/deploy/images/build.sh" "$@" || fail "deploy/images/build.sh failed"
    say "images ready in $((SECONDS - t)) s"
  fi
}

# Waits until every running container of the project reports healthy (bounded).
wait_healthy() {
  local limit=$1 deadline=$((SECONDS + $1)) ids states bad
  while :; do
    ids=$(dc ps -q 2>/dev/null)
    if [[ -n "$ids" ]]; then
      states=$(docker inspect -f '{{.Name}} {{.State.Status}} {{if .State.Health}}{{.State.Health.Status}}{{else}}none{{end}}' $ids)
      bad=$(awk '$2 != "running" || ($3 != "healthy" && $3 != "none")' <<<"$states")
      [[ -z "$bad" ]] && return 0
      if awk '$2 == "exited" || $2 == "dead" || $3 == "unhealthy"' <<<"$states" | grep -q .; then
        fail "a container failed: $(awk '$2 != "running" || $3 == "unhealthy"' <<<"$states" | tr '\n' ';')"
      fi
    fi
    ((SECONDS < deadline)) || fail "not healthy within $limit s: $(tr '\n' ';' <<<"$bad")"
    sleep 1
  done
}

compose_up() {
  local t=$SECONDS
  step "compose up (${compose_cmd[*]}, project $project)"
  dc up -d >"$tmp/up.log" 2>&1 || { cat "$tmp/up.log"; fail "compose up failed"; }
  wait_healthy 120
  say "all containers healthy $((SECONDS - t)) s after 'up'"
}

# For the teardown of a failed run: the step, the containers' state and their last log lines.
report_project() {
  echo "==== step failed: ${failed_step:-setup}; container state:"
  dc ps -a 2>&1 || true
  echo "==== container logs (last 80 lines each)"
  DC_TIMEOUT=60 dc logs --no-color --tail=80 2>&1 || true
}

down_project() {
  say "tearing down $project"
  DC_TIMEOUT=120 dc down -v --remove-orphans -t 5 >/dev/null 2>&1 || echo "$test_name: teardown of $project failed" >&2
}

# ---- between the spaces (sam1: kr's SAM's host name; mgr1: jp's manager's) -----------------------
jp_listed() { kr ls "jp/$1" | grep -qE "^jp/$1 +\S+ +\S+ +bridge-kr +available +dds:jp/$1\$"; }
kr_bound() { jp rtc ls bridge-jp.host_cxt | grep -q "$1"; }
cross_space_echoes() {  # TEXT: kr calls jp's diagnostic echo, and jp's RT consumer kr's
  local out
  out=$(kr call "jp/Diagnostic0.diagnostic@$mgr1" echo "{\"text\":\"$1 from kr\"}") || fail "cross-space call: $(cat "$tmp/cli.err")"
  [[ "$out" == "{\"result\":\"$1 from kr\"}" ]] || fail "cross-space echo answered $out"
  out=$(jp rtc call "bridge-jp.host_cxt/kr_diag-$sam1.rtc:diagnostic" echo "{\"text\":\"$1 from jp\"}") \
    || fail "cross-space RT call: $(cat "$tmp/cli.err")"
  [[ "$out" == "{\"result\":\"$1 from jp\"}" ]] || fail "cross-space RT echo answered $out"
}
