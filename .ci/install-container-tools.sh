#!/usr/bin/env bash
# Installs what tests/container.rs needs to build and run the image, on a
# Debian/Ubuntu CI machine, as root, with no standard input. Idempotent: a
# re-run finds everything in place and returns in about a second.
#
# - A Docker engine that answers `docker info` needs nothing: the test uses it
#   with the public base images.
# - Otherwise it installs podman, runc and debootstrap, drops podman's default
#   ulimits (they fail on these machines), and creates the local base image
#   `localhost/debian:bookworm-slim` with debootstrap, because no registry can
#   be reached here (see README "Container").
#
# It fails (exit 1, with the reason on stderr) when something cannot be
# installed, so that CI stops there rather than skipping the container test.
# On success it prints one line.
set -uo pipefail
export DEBIAN_FRONTEND=noninteractive

BASE_IMAGE="${ISOREMESH_CI_BASE_IMAGE:-localhost/debian:bookworm-slim}"
SUITE="${ISOREMESH_CI_SUITE:-bookworm}"

NAME=install-container-tools
log=/tmp/isoremesh-install-container-tools.log
# shellcheck source=lib.sh
. "$(dirname "$0")/lib.sh"

if docker info >/dev/null 2>&1; then
    echo "install-container-tools: a Docker engine answers; nothing to install"
    exit 0
fi

if [ "$(id -u)" != 0 ]; then
    fail "not root and no Docker engine: cannot install podman"
fi

installed=""
need=()
command -v podman >/dev/null 2>&1 || need+=(podman)
command -v runc >/dev/null 2>&1 || need+=(runc)
command -v debootstrap >/dev/null 2>&1 || need+=(debootstrap)
if [ "${#need[@]}" -gt 0 ]; then
    if ! command -v apt-get >/dev/null 2>&1; then
        fail "no apt-get; cannot install ${need[*]}"
    fi
    if ! retry apt-get update -q >>"$log" 2>&1; then
        say "apt-get update failed; trying the install anyway"
    fi
    if ! retry apt-get install -y -q --no-install-recommends "${need[@]}" ca-certificates >>"$log" 2>&1; then
        fail "could not install ${need[*]} (log: $log)"
    fi
    installed="installed ${need[*]}; "
fi

# crun (podman's default runtime) fails on these machines, and so do the
# default ulimits; the test passes --runtime runc, this drops the ulimits.
# An existing containers.conf is left alone unless it lacks the setting.
conf=/etc/containers/containers.conf
mkdir -p /etc/containers
if [ ! -e "$conf" ]; then
    printf '[containers]\ndefault_ulimits = []\n' >"$conf"
elif ! grep -q '^[[:space:]]*default_ulimits' "$conf"; then
    if grep -q '^\[containers\]' "$conf"; then
        sed -i 's/^\[containers\]$/[containers]\ndefault_ulimits = []/' "$conf"
    else
        printf '\n[containers]\ndefault_ulimits = []\n' >>"$conf"
    fi
fi

# The local base image stands in for debian:bookworm-slim. The image itself is
# the marker: once it exists this step is skipped.
if podman image exists "$BASE_IMAGE"; then
    echo "install-container-tools: ${installed}podman, runc and $BASE_IMAGE present"
    exit 0
fi
rootfs="$(mktemp -d /tmp/isoremesh-rootfs.XXXXXX)"
trap 'rm -rf "$rootfs"' EXIT
# debootstrap leaves a half-made tree behind when a download fails; each
# attempt starts from an empty directory.
attempt() {
    rm -rf "$rootfs" && mkdir -p "$rootfs" &&
        debootstrap --variant=minbase "$SUITE" "$rootfs" >/tmp/isoremesh-debootstrap.log 2>&1
}
if ! retry attempt; then
    fail "debootstrap failed (log: /tmp/isoremesh-debootstrap.log)"
fi
# Trim what a container never uses, as the official slim image does.
rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/* \
    "$rootfs"/usr/share/doc/* "$rootfs"/usr/share/man/* "$rootfs"/usr/share/locale/*
if ! tar -C "$rootfs" -c . | podman import - "$BASE_IMAGE" >/dev/null 2>>"$log"; then
    fail "podman import of $BASE_IMAGE failed"
fi
echo "install-container-tools: ${installed}created $BASE_IMAGE with debootstrap"
