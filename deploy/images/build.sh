#!/usr/bin/env bash
# Builds every URSLink image from the host-built binaries: base (offline, from Debian packages),
# staging, then one `docker build --target` per service, tagged urslink/<service>:${URS_IMAGE_TAG:-dev}.
#   deploy/images/build.sh [SERVICE...]    (default: every service; the bridge only when built)
# Environment:
#   URS_BUILD_DIR      where the binaries are (default build/; run deploy/build.sh first)
#   URS_IMAGE_BASE     base image (default urslink/base:bookworm, made by make-base.sh when missing;
#                      debian:bookworm-slim on a machine that can pull)
#   URS_IMAGE_TAG      tag of the service images (default dev)
#   URS_IMAGE_CONTEXT  staging folder (default $URS_BUILD_DIR/image-context)
# Docker's layer cache makes a rebuild with unchanged binaries take seconds.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
export URS_BUILD_DIR=${URS_BUILD_DIR:-$root/build}
base=${URS_IMAGE_BASE:-urslink/base:bookworm}
tag=${URS_IMAGE_TAG:-dev}
ctx=${URS_IMAGE_CONTEXT:-$URS_BUILD_DIR/image-context}
services=("$@")
((${#services[@]})) || services=(rtc-naming camus-server sam-host rtc-manager cli bridge gateway prometheus)

command -v docker >/dev/null || { echo "images: docker is not installed" >&2; exit 1; }
docker info >/dev/null 2>&1 || { echo "images: the docker daemon does not answer (is it running? may this user use it?)" >&2; exit 1; }

t0=$SECONDS
if [[ "$base" == urslink/base:* ]]; then
  URS_BASE_IMAGE=$base "$here/make-base.sh"
elif ! docker image inspect "$base" >/dev/null 2>&1; then
  docker pull "$base"
fi
t_base=$((SECONDS - t0))

"$here/stage.sh" "$ctx"
"$root/compose/make-token.sh"  # the Planet token compose gives space kr (a secret, not in an image)
"$root/compose/make-certs.sh"  # kr's CA and CAMUS server certificate: kr's Planet runs over TLS 1.3
"$root/compose/make-pki.sh"    # the federation PKI: the link between the spaces runs on DDS-Security
# kr's operators' own credential (compose/config/kr-credentials.yaml): the dashboard's login.
"$root/compose/make-token.sh" "${URS_KR_OPERATOR_TOKEN_FILE:-$root/compose/config/kr-operator.token}"
# jp's gateway: the credential its operators log in with (jp has no CAMUS server to check one).
"$root/compose/make-token.sh" "${URS_JP_TOKEN_FILE:-$root/compose/config/jp.token}"

for service in "${services[@]}"; do
  if [[ $service == bridge && ! -x "$ctx/opt/urslink/bin/urs-bridge" ]]; then
    echo "images: skipping bridge (urs-bridge not built)"
    continue
  fi
  t=$SECONDS
  log=$(mktemp)
  if ! docker build -f "$here/Dockerfile" --target "$service" --build-arg "BASE=$base" \
         -t "urslink/$service:$tag" "$ctx" >"$log" 2>&1; then
    echo "images: building urslink/$service:$tag failed:" >&2
    tail -40 "$log" >&2
    rm -f "$log"
    exit 1
  fi
  rm -f "$log"
  echo "images: urslink/$service:$tag  $(docker image inspect -f '{{.Size}}' "urslink/$service:$tag" | numfmt --to=iec)  ($((SECONDS - t)) s)"
done
echo "images: done in $((SECONDS - t0)) s (base $t_base s)"
