#!/usr/bin/env bash
# Writes the federation PKI of the compose link when there is none yet (deploy/pki.sh): a CA, the
# governance (every topic encrypted), and one member per participant of the `link` network:
#   jp, kr                      the spaces' bridges, each granted calls to the other
#   urs-gateway.jp, urs-gateway.kr   the gateways, which read the link and call nobody
#   spy                         granted no calls, no answers, and reads of kr's shared topics only;
#                               run by no service: the valid member tests/e2e/containers/run.sh
#                               lets loose as an intruder
# deploy/images/build.sh runs it, like the tokens. Compose gives each container its own member
# folder and the public files (ca.pem, governance.p7s, crl.pem), never the CA's key, and the
# bridges join the link secured (dds.security in config/*-bridge.yaml; docs/federation.md).
#   compose/make-pki.sh [DIR]    (default: ${URS_PKI_DIR:-compose/config/pki})
# The keys stay readable by others (0644), as the TLS key: the containers' user 10001 reads them
# through bind mounts. Delete the folder to make a new federation; a folder made for other members
# or grants (DIR/members.txt differs), or one whose files `deploy/pki.sh check` refuses (expired,
# revoked, made before partitions), is made again.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
dir=${1:-${URS_PKI_DIR:-$here/config/pki}}
pki=$here/../deploy/pki.sh
# Each member and its grants (deploy/pki.sh member DIR ...).
grants=(
  "jp --calls kr"
  "kr --calls jp"
  "urs-gateway.jp --callers ''"
  "urs-gateway.kr --callers ''"
  "spy --callers '' --reads kr"
)
members=()
for g in "${grants[@]}"; do members+=("${g%% *}"); done
complete() {
  local m
  [[ -s "$dir/ca.pem" && -s "$dir/governance.p7s" && -s "$dir/crl.pem" ]] || return 1
  [[ "$(cat "$dir/members.txt" 2>/dev/null)" == "$(printf '%s\n' "${grants[@]}")" ]] || return 1
  for m in "${members[@]}"; do "$pki" check "$dir" "$m" >/dev/null 2>&1 || return 1; done
}
complete && exit 0
rm -rf "$dir"
"$pki" init "$dir" --name "URSLink compose federation" >/dev/null
"$pki" governance "$dir" >/dev/null
for g in "${grants[@]}"; do eval "\"\$pki\" member \"\$dir\" $g" >/dev/null; done
printf '%s\n' "${grants[@]}" >"$dir/members.txt"
chmod 0755 "$dir"
chmod 0644 "$dir/governance.p7s" "$dir/members.txt"
for m in "${members[@]}"; do chmod 0755 "$dir/$m" && chmod 0644 "$dir/$m"/*; done
echo "compose: wrote a new federation PKI (CA, governance, members ${members[*]}) to $dir"
