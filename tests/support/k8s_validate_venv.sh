#!/usr/bin/env bash
# kubernetes-validate (PyPI; it ships the Kubernetes JSON schemas of each version) in a venv at $1,
# made once and reused: the k8s_manifests test validates the rendered manifests with it.
# Prints the venv's kubernetes-validate on success. Exit 77 when PyPI cannot be reached (the test
# skips and says so), 1 on any other failure.
set -euo pipefail
venv=${1:?usage: k8s_validate_venv.sh VENV_DIR}
"$(dirname "$0")/pypi_venv.sh" "$venv" kubernetes-validate 1.37.0 >/dev/null
echo "$venv/bin/kubernetes-validate"
