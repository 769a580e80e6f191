#!/usr/bin/env bash
# Makes the base image urslink/base:bookworm from Debian packages alone (no registry needed):
#   debootstrap --variant=minbase bookworm <dir> <mirror>  |  tar | docker import
# Idempotent: does nothing when the image exists (URS_BASE_REBUILD=1 forces a rebuild).
# The mirror is the one apt uses on this machine (URS_DEBIAN_MIRROR overrides it).
# The image is also tagged urslink/base:bookworm-slim so a Dockerfile written for
# `ARG BASE=debian:bookworm-slim` builds on it with `--build-arg BASE=urslink/base:bookworm`.
set -euo pipefail

image=${URS_BASE_IMAGE:-urslink/base:bookworm}
suite=bookworm

command -v docker >/dev/null || { echo "make-base: docker is not installed" >&2; exit 1; }
if [[ "${URS_BASE_REBUILD:-0}" != 1 ]] && docker image inspect "$image" >/dev/null 2>&1; then
  echo "make-base: $image exists ($(docker image inspect -f '{{.Size}}' "$image" | numfmt --to=iec)), nothing to do"
  exit 0
fi

# The Debian mirror apt uses here: deb822 .sources files first, then one-line sources.list entries.
find_mirror() {
  local f uri
  for f in /etc/apt/sources.list.d/*.sources; do
    [[ -f $f ]] || continue
    uri=$(awk '/^URIs:/ {for (i = 2; i <= NF; i++) if ($i !~ /security/) {print $i; exit}}' "$f")
    [[ -n $uri ]] && { echo "$uri"; return; }
  done
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [[ -f $f ]] || continue
    uri=$(awk '$1 == "deb" && $0 ~ /'"$suite"'/ && $0 !~ /security/ {
                 for (i = 2; i <= NF; i++) if ($i ~ /^(https?|file):/) {print $i; exit}}' "$f")
    [[ -n $uri ]] && { echo "$uri"; return; }
  done
  echo http://deb.debian.org/debian
}
mirror=${URS_DEBIAN_MIRROR:-$(find_mirror)}

SUDO=""
[[ $(id -u) -eq 0 ]] || SUDO="sudo"
if ! command -v debootstrap >/dev/null; then
  echo "make-base: installing debootstrap"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends debootstrap \
    || { $SUDO apt-get update -q && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends debootstrap; }
fi

dir=$(mktemp -d /tmp/urs-base.XXXXXX)
cleanup() { $SUDO rm -rf "$dir"; }
trap cleanup EXIT

echo "make-base: debootstrap --variant=minbase $suite from $mirror (about a minute)"
start=$SECONDS
$SUDO debootstrap --variant=minbase "$suite" "$dir/root" "$mirror" >"$dir/debootstrap.log" 2>&1 || {
  echo "make-base: debootstrap failed; its log:" >&2; tail -30 "$dir/debootstrap.log" >&2
  tail -30 "$dir/root/debootstrap/debootstrap.log" >&2 2>/dev/null || true
  exit 1
}
root=$dir/root

# What debian:bookworm-slim does to be small and container-friendly.
$SUDO tee "$root/etc/apt/sources.list" >/dev/null <<SOURCES
deb $mirror $suite main
deb $mirror $suite-updates main
SOURCES
if [[ "$mirror" == http://deb.debian.org/debian ]]; then
  echo "deb http://deb.debian.org/debian-security $suite-security main" | $SUDO tee -a "$root/etc/apt/sources.list" >/dev/null
fi
# No daemons started by package scripts inside a container.
printf '#!/bin/sh\nexit 101\n' | $SUDO tee "$root/usr/sbin/policy-rc.d" >/dev/null
$SUDO chmod 755 "$root/usr/sbin/policy-rc.d"
$SUDO tee "$root/etc/apt/apt.conf.d/docker-clean" >/dev/null <<'APT'
DPkg::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
APT::Update::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
Dir::Cache::pkgcache "";
Dir::Cache::srcpkgcache "";
APT
$SUDO tee "$root/etc/apt/apt.conf.d/docker-no-recommends" >/dev/null <<'APT'
APT::Install-Recommends "false";
APT::Install-Suggests "false";
APT
$SUDO tee "$root/etc/dpkg/dpkg.cfg.d/docker-excludes" >/dev/null <<'DPKG'
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/info/*
path-exclude /usr/share/locale/*
path-exclude /usr/share/lintian/*
DPKG
$SUDO find "$root/usr/share/doc" -mindepth 2 ! -name copyright -type f -delete 2>/dev/null || true
$SUDO rm -rf "$root"/usr/share/man/* "$root"/usr/share/info/* "$root"/usr/share/locale/* \
  "$root"/var/cache/apt/archives/*.deb "$root"/var/cache/apt/*.bin "$root"/var/lib/apt/lists/* \
  "$root"/var/log/* "$root"/tmp/* "$root"/debootstrap
: | $SUDO tee "$root/etc/hostname" >/dev/null
$SUDO rm -f "$root/etc/resolv.conf" "$root/etc/hosts"  # docker provides them

$SUDO tar --numeric-owner -C "$root" -c . | docker import \
  --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
  --change 'CMD ["bash"]' \
  --message "debootstrap --variant=minbase $suite $mirror" - "$image" >/dev/null
docker tag "$image" "${image%%:*}:$suite-slim"
echo "make-base: $image made in $((SECONDS - start)) s, $(docker image inspect -f '{{.Size}}' "$image" | numfmt --to=iec)"
