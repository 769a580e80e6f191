#!/usr/bin/env bash
# services_description: compose, the images, the entry point, the programs' flags, the Kubernetes
# manifests and the systemd units agree with deploy/services/services.yaml (urs-services check); and
# the check does fail, naming the disagreement, when any one of them drifts: each drift below is made
# in a copy of those files and must be reported.
#   services_description_test.sh SOURCE_DIR BUILD_DIR
set -uo pipefail
root=$1
build=$2
work=$build/services-description-test
test_name=services_description
source "$(dirname "$0")/../../support/process_test.sh"
check=$root/deploy/services/urs-services

"$check" check --build "$build" >"$work.log" 2>&1 || { cat "$work.log"; fail "the tree disagrees with its description"; }
cat "$work.log"

# A copy of what the check reads (services/ by a link: the programs' sources).
copy() {
  rm -rf "$work"
  mkdir -p "$work/deploy/images" "$work/compose"
  cp -r "$root/deploy/services" "$root/deploy/k8s" "$root/deploy/systemd" "$work/deploy/"
  cp -r "$root/deploy/images/Dockerfile" "$root/deploy/images/bin" "$work/deploy/images/"
  cp -r "$root/compose/docker-compose.yml" "$root/compose/config" "$work/compose/"
  ln -s "$root/services" "$work/services"
}
# expect_drift WHAT EXPECTED-MESSAGE: the check of the copy fails and says EXPECTED-MESSAGE.
expect_drift() {
  local out
  out=$("$check" check --root "$work" --build "$build" 2>&1)
  local rc=$?
  [[ $rc -eq 1 ]] || fail "$1: the check exited $rc, not 1: $out"
  grep -qF -- "$2" <<<"$out" || fail "$1: the check did not say '$2': $out"
  echo "services_description: $1: reported"
}

copy
sed -i 's|^\(      URS_CONFIG: /etc/urslink/sam.yaml\)$|\1\n      URS_WORKERS: "8"|' "$work/compose/docker-compose.yml"
expect_drift "a variable added to compose only" "compose services.sam-host.environment.URS_WORKERS: in compose/docker-compose.yml"

copy
sed -i 's|"\${token\[@\]}" "\${tls\[@\]}" "\${common\[@\]}" "\$@" ;;|--stats "${URS_STATS:-}" &|' \
  "$work/deploy/images/bin/urs-entrypoint"
grep -q -- '--stats' "$work/deploy/images/bin/urs-entrypoint" || fail "the drift was not made in urs-entrypoint"
expect_drift "a flag added to the entry point only" "roles.sam-host.flags: urs-entrypoint gives urs-sam --stats"
expect_drift "a variable added to the entry point only" "urs-health reads URS_STATS, the description does not list it"

copy
sed -i 's|flags: \[--space, --server, --config, --token-file, --tls-ca, --log-level, --metrics-listen\]|flags: [--space, --server, --config, --token-file, --tls-ca, --log-level, --metrics-listen, --no-such-flag]|' \
  "$work/deploy/services/services.yaml"
expect_drift "a flag the program does not take" "roles.sam-host.flags: urs-sam --help has no --no-such-flag"

copy
sed -i '0,/--start-period=20s/s//--start-period=25s/' "$work/deploy/images/Dockerfile"
expect_drift "a health check changed in the Dockerfile only" "Dockerfile target rtc-naming (role naming): HEALTHCHECK"

copy
sed -i 's|readOnlyRootFilesystem: true|readOnlyRootFilesystem: false|' "$work/deploy/k8s/base/bridge.yaml"
expect_drift "a generated manifest edited by hand" "deploy/k8s/base/bridge.yaml: not what the description gives"

copy
sed -i 's|^NoNewPrivileges=yes$||' "$work/deploy/systemd/urs-camus-server.service"
expect_drift "a generated unit edited by hand" "deploy/systemd/urs-camus-server.service: not what the description gives"

copy
sed -i 's|^        volume: kr-camus$|        volume: kr-camus-data|' "$work/deploy/services/services.yaml"
expect_drift "a volume renamed in the description only" "compose services.camus-server.volumes"
rm -rf "$work"
echo "services_description: the tree agrees with deploy/services/services.yaml, and each drift is reported"
