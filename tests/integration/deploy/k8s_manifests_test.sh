#!/usr/bin/env bash
# k8s_manifests: every kustomization of deploy/k8s renders (kubectl kustomize: the base, the parts
# of a CAMUS and of an RT space, and each space's overlay), and every object it gives, with the
# Secrets deploy/k8s/make-secrets.sh makes for each space, validates against the JSON schemas of
# Kubernetes $version (kubernetes-validate --strict: no unknown field either); then what no schema
# sees (k8s_references.py): mounts, addresses, environments, hardening, the link policy.
# No cluster runs here: nothing is applied.
#   k8s_manifests_test.sh SOURCE_DIR BUILD_DIR
set -uo pipefail
root=$1
build=$2
work=$build/k8s-manifests-test
test_name=k8s_manifests
version=1.32.0  # the Kubernetes version the manifests are validated against (docs/deployment.md)
source "$(dirname "$0")/../../support/process_test.sh"
here=$(cd "$(dirname "$0")" && pwd)

command -v kubectl >/dev/null || fail "kubectl is missing (Debian: apt-get install kubernetes-client)"
validate=$("$root/tests/support/k8s_validate_venv.sh" "$build/venv-k8s-validate")
rc=$?
[[ $rc -eq 77 ]] && { echo "k8s_manifests: SKIPPED: PyPI not reachable for kubernetes-validate"; exit 77; }
[[ $rc -eq 0 ]] || fail "cannot install kubernetes-validate"
rm -rf "$work"
mkdir -p "$work/files"

# The Secrets, from files made here (never the tree's own tokens and keys).
export URS_KR_TOKEN_FILE=$work/files/kr.token URS_KR_OPERATOR_TOKEN_FILE=$work/files/kr-operator.token
export URS_JP_TOKEN_FILE=$work/files/jp.token URS_KR_TLS_DIR=$work/files/kr-tls URS_PKI_DIR=$work/files/pki
for space in kr jp; do
  "$root/deploy/k8s/make-secrets.sh" "$space" >"$work/$space-secrets.yaml" 2>"$work/secrets.log" ||
    fail "make-secrets.sh $space failed: $(cat "$work/secrets.log")"
done

kubectl version --client >"$work/kubectl.log" 2>&1
echo "k8s_manifests: $(head -1 "$work/kubectl.log"); kubernetes-validate $("$validate" --version), schemas of Kubernetes $version"
for dir in base camus rt overlays/kr overlays/jp; do
  out=$work/$(basename "$dir").yaml
  kubectl kustomize "$root/deploy/k8s/$dir" >"$out" 2>"$work/kustomize.log" || fail "kubectl kustomize $dir: $(cat "$work/kustomize.log")"
  # kustomize 5 warns that bases and patchesStrategicMerge are deprecated: they are what kustomize 2
  # (Debian's kubectl 1.20) reads too. Anything else it says fails the test.
  unexpected=$(grep -v "^# Warning: '\(bases\|patchesStrategicMerge\)' is deprecated" "$work/kustomize.log")
  [[ -z "$unexpected" ]] || fail "kubectl kustomize $dir: $unexpected"
  files=("$out")
  [[ $dir == overlays/* ]] && files+=("$work/$(basename "$dir")-secrets.yaml")
  for file in "${files[@]}"; do
    result=$("$validate" --strict --quiet -k "$version" "$file" 2>&1) || fail "$dir: $(basename "$file") does not validate: $result"
  done
  count=$(grep -c '^kind:' "$out")
  echo "k8s_manifests: $dir: $count objects render and validate"
done
for space in kr jp; do
  python3 "$here/k8s_references.py" "$root" "$space" "$work/$space.yaml" "$work/$space-secrets.yaml" || fail "overlays/$space"
done
echo "k8s_manifests: every kustomization renders, validates against Kubernetes $version and references what exists"
