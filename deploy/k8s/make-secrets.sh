#!/usr/bin/env bash
# The Secrets of a space's overlay, from the same files compose uses (written here when missing, as
# deploy/images/build.sh does): kr's Planet tokens and TLS files, jp's gateway token, and the
# federation PKI's public files and the space's members (its bridge's and its gateway's folders).
#   deploy/k8s/make-secrets.sh SPACE > SPACE-secrets.yaml    then: kubectl apply -f SPACE-secrets.yaml
# The output holds private keys and tokens: keep it out of version control. The files' places follow
# compose's variables (URS_KR_TOKEN_FILE, URS_KR_TLS_DIR, URS_PKI_DIR, ...); docs/deployment.md,
# "Kubernetes".
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
space=${1:?usage: make-secrets.sh SPACE}
{
  "$root/compose/make-token.sh"
  "$root/compose/make-token.sh" "${URS_KR_OPERATOR_TOKEN_FILE:-$root/compose/config/kr-operator.token}"
  "$root/compose/make-token.sh" "${URS_JP_TOKEN_FILE:-$root/compose/config/jp.token}"
  "$root/compose/make-certs.sh"
  "$root/compose/make-pki.sh"
} >&2
exec "$root/deploy/services/urs-services" k8s-secrets "$space"
