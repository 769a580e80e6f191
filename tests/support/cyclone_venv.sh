#!/usr/bin/env bash
# Eclipse Cyclone DDS's Python binding (PyPI "cyclonedds", whose wheel bundles libddsc) in a venv
# at $1, made once and reused: the second DDS vendor of the interoperability tests.
# Prints the venv's python on success. Exit 77 when PyPI cannot be reached (the tests skip and say
# so), 1 on any other failure.
set -euo pipefail
exec "$(dirname "$0")/pypi_venv.sh" "${1:?usage: cyclone_venv.sh VENV_DIR}" cyclonedds 11.0.1
