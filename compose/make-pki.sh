#!/usr/bin/env bash
# Writes the federation PKI of the compose link when there is none yet (deploy/pki.sh): a CA, the
# governance (every topic encrypted), and one member per participant of the `link` network:
#   jp, kr                      the spaces' bridges, each granted calls to the other
#   urs-gateway.jp, urs-gateway.kr   the gateways, which read the link and call nobody
#   spy                         granted nothing (no calls, no answers) and run by no service: the
#                               valid member tests/e2e/containers/run.sh lets loose as an intruder
# deploy/images/build.sh runs it, like the tokens. Compose gives each container its own member
# folder and the public files (ca.pem, governance.p7s, crl.pem), never the CA's key, and the
# bridges join the link secured (dds.security in config/*-bridge.yaml; docs/federation.md).
#   compose/make-pki.sh [DIR]    (default: ${URS_PKI_DIR:-compose/config/pki})
# The keys stay readable by others (0644), as the TLS key: the containers' user 10001 reads them
# through bind mounts. Delete the folder to make a new federation.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
dir=${1:-${URS_PKI_DIR:-$here/config/pki}}
pki=$here/../deploy/pki.sh
members=(jp kr urs-gateway.jp urs-gateway.kr spy)
complete() {
  local m
  [[ -s "$dir/ca.pem" && -s "$dir/governance.p7s" && -s "$dir/crl.pem" ]] || return 1
  for m in "${members[@]}"; do [[ -s "$dir/$m/permissions.p7s" ]] || return 1; done
}
complete && exit 0
rm -rf "$dir"
"$pki" init "$dir" --name "URSLink compose federation" >/dev/null
"$pki" governance "$dir" >/dev/null
"$pki" member "$dir" jp --calls kr >/dev/null
"$pki" member "$dir" kr --calls jp >/dev/null
"$pki" member "$dir" urs-gateway.jp --callers "" >/dev/null
"$pki" member "$dir" urs-gateway.kr --callers "" >/dev/null
"$pki" member "$dir" spy --callers "" >/dev/null
chmod 0755 "$dir"
chmod 0644 "$dir/governance.p7s"
for m in "${members[@]}"; do chmod 0755 "$dir/$m" && chmod 0644 "$dir/$m"/*; done
echo "compose: wrote a new federation PKI (CA, governance, members ${members[*]}) to $dir"
