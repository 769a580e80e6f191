#!/usr/bin/env bash
# Eclipse Cyclone DDS's Python binding (PyPI "cyclonedds", whose wheel bundles libddsc) in a venv
# at $1, made once and reused: the second DDS vendor of the interoperability tests.
# Prints the venv's python on success. Exit 77 when PyPI cannot be reached (the tests skip and say
# so), 1 on any other failure.
set -euo pipefail
venv=${1:?usage: cyclone_venv.sh VENV_DIR}
version=11.0.1
python=$venv/bin/python
if [ -x "$python" ] && "$python" -c "import cyclonedds, sys; sys.exit(cyclonedds.__version__ != '$version')" 2>/dev/null; then
  echo "$python"
  exit 0
fi
exec 9>"$venv.lock"
flock 9  # tests running side by side make it once
if ! [ -x "$python" ]; then python3 -m venv "$venv" >&2; fi
if ! log=$("$python" -m pip install --disable-pip-version-check -q "cyclonedds==$version" 2>&1); then
  echo "$log" >&2
  if grep -qiE "network|connection|resolve|timed out|unreachable|No matching distribution" <<<"$log"; then
    echo "cyclone_venv.sh: PyPI is not reachable: cannot install cyclonedds==$version" >&2
    exit 77
  fi
  exit 1
fi
echo "$python"
