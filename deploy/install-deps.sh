#!/usr/bin/env bash
# Installs, by Debian package name, everything URSLink needs to build, test and run.
# Idempotent: packages already present are skipped, and nothing is downloaded when all are there.
# Usage: deploy/install-deps.sh [--with-fuzz]   (adds clang + libFuzzer for the fuzz targets)
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git ca-certificates
  clang-format clang-tidy  # deploy/lint.sh: the layout and the names (.clang-format, .clang-tidy)
  mold  # the linker (cmake/UrsBuildSpeed.cmake: URS_LINKER)
  # required stack
  libprotobuf-dev protobuf-compiler python3-protobuf
  libprotoc-dev  # protobuf::libprotoc (compiler::Importer) for urs::schema load_idl()
  libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev
  libomniorb4-dev omniidl omniorb-nameserver omniorb
  libfastrtps-dev libfastcdr-dev fastddsgen default-jre-headless  # fastddsgen runs on Java
  # supporting libraries
  libasio-dev libcli11-dev libyaml-cpp-dev libsqlite3-dev
  libssl-dev  # OpenSSL libcrypto: token hashes (SHA-256), constant-time compare, session secrets
  libespeak-ng-dev libpocketsphinx-dev libsphinxbase-dev pocketsphinx-en-us  # speech devices
  libqrencode-dev libzbar-dev libpng-dev  # camera device: QR markers, their recognition, PNG frames
  libboost-dev  # urs-gateway: Boost.Beast (HTTP and WebSocket, header-only)
  prometheus-cpp-dev  # urs::metrics: the metric registry and the Prometheus text format
  libgrpc++-dev protobuf-compiler-grpc  # urs-bench's gRPC baseline rows
  # tools used by tests and scripts
  python3 procps iproute2 nftables  # nftables: the two-hosts test's sites pass no multicast
  python3-venv  # the rtshell and Cyclone DDS interoperability tests install their peers from PyPI into venvs
  python3-websockets python3-selenium chromium chromium-driver  # the gateway's protocol and browser tests
  python3-jsonschema  # the gateway's schema test validates what every channel carries
  prometheus  # promtool check metrics on every program's /metrics
  # containers: the engine, compose, and debootstrap for the base image made from Debian packages
  docker.io docker-compose debootstrap
  # deploy/services/urs-services (python3-yaml), the units' systemd-analyze verify (systemd)
  python3-yaml systemd
)
# kubectl renders the Kubernetes overlays (kubectl kustomize): Debian's kubernetes-client, unless a
# kubectl is installed already (another package's would conflict with it).
command -v kubectl >/dev/null || PACKAGES+=(kubernetes-client)
if [[ "${1:-}" == "--with-fuzz" ]]; then
  PACKAGES+=(clang libclang-rt-14-dev)
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
