#!/usr/bin/env bash
# One package from PyPI, pinned, in a venv at VENV made once and reused by the tests that need a
# peer or a library Debian does not package (the tests' venvs; deploy/install-deps.sh installs
# Debian packages only). --system-site-packages: the venv also sees Debian's Python packages.
#   pypi_venv.sh [--system-site-packages] VENV PACKAGE VERSION
# Prints the venv's python on success. Exit 77 when PyPI cannot be reached (the tests skip and say
# so), 1 on any other failure.
set -euo pipefail
site=()
if [ "${1:-}" = "--system-site-packages" ]; then site=(--system-site-packages); shift; fi
venv=${1:?usage: pypi_venv.sh [--system-site-packages] VENV PACKAGE VERSION}
package=${2:?package}
version=${3:?version}
python=$venv/bin/python
installed() { "$python" -c "import importlib.metadata as m, sys; sys.exit(m.version('$package') != '$version')" 2>/dev/null; }
if [ -x "$python" ] && installed; then
  echo "$python"
  exit 0
fi
mkdir -p "$(dirname "$venv")"
exec 9>"$venv.lock"
flock 9  # tests running side by side make it once
if ! [ -x "$python" ]; then /usr/bin/python3 -m venv "${site[@]}" "$venv" >&2; fi
if ! installed; then
  if ! log=$("$python" -m pip install --disable-pip-version-check -q "$package==$version" 2>&1); then
    echo "$log" >&2
    if grep -qiE "network|connection|resolve|timed out|unreachable|No matching distribution" <<<"$log"; then
      echo "pypi_venv.sh: PyPI is not reachable: cannot install $package==$version" >&2
      exit 77
    fi
    exit 1
  fi
fi
echo "$python"
