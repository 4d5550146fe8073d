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
# It never fails CI: if something cannot be installed (apt down, not root),
# it says so and exits 0, and the container test then skips with a message.
set -uo pipefail
export DEBIAN_FRONTEND=noninteractive

BASE_IMAGE="${ISOREMESH_CI_BASE_IMAGE:-localhost/debian:bookworm-slim}"
SUITE="${ISOREMESH_CI_SUITE:-bookworm}"

say() { echo "install-container-tools: $*" >&2; }

# Runs "$@" up to 4 times, 10 s apart: a mirror that is briefly unavailable
# should not turn into a skipped test.
retry() {
    local n
    for n in 1 2 3 4; do
        if "$@"; then return 0; fi
        say "attempt $n failed: $*"
        [ "$n" -lt 4 ] && sleep 10
    done
    return 1
}

if docker info >/dev/null 2>&1; then
    say "a Docker engine answers; nothing to install"
    exit 0
fi

if [ "$(id -u)" != 0 ]; then
    say "not root: cannot install podman; the container test will skip unless an engine is present"
    exit 0
fi

need=()
command -v podman >/dev/null 2>&1 || need+=(podman)
command -v runc >/dev/null 2>&1 || need+=(runc)
command -v debootstrap >/dev/null 2>&1 || need+=(debootstrap)
if [ "${#need[@]}" -gt 0 ]; then
    if ! command -v apt-get >/dev/null 2>&1; then
        say "no apt-get; cannot install ${need[*]}"
        exit 0
    fi
    say "installing ${need[*]}"
    if ! retry apt-get update -q; then
        say "apt-get update failed; trying the install anyway"
    fi
    if ! retry apt-get install -y -q --no-install-recommends "${need[@]}" ca-certificates; then
        say "could not install ${need[*]}; the container test will skip"
        exit 0
    fi
fi

# crun (podman's default runtime) fails on these machines, and so do the
# default ulimits; the test passes --runtime runc, this drops the ulimits.
# An existing containers.conf is left alone unless it lacks the setting.
conf=/etc/containers/containers.conf
mkdir -p /etc/containers
if [ ! -e "$conf" ]; then
    printf '[containers]\ndefault_ulimits = []\n' >"$conf"
    say "wrote $conf"
elif ! grep -q '^[[:space:]]*default_ulimits' "$conf"; then
    if grep -q '^\[containers\]' "$conf"; then
        sed -i 's/^\[containers\]$/[containers]\ndefault_ulimits = []/' "$conf"
    else
        printf '\n[containers]\ndefault_ulimits = []\n' >>"$conf"
    fi
    say "added default_ulimits = [] to $conf"
fi

# The local base image stands in for debian:bookworm-slim. The image itself is
# the marker: once it exists this step is skipped.
if podman image exists "$BASE_IMAGE"; then
    say "$BASE_IMAGE present"
    exit 0
fi
rootfs="$(mktemp -d /tmp/isoremesh-rootfs.XXXXXX)"
trap 'rm -rf "$rootfs"' EXIT
say "creating $BASE_IMAGE with debootstrap (about a minute)"
# debootstrap leaves a half-made tree behind when a download fails; each
# attempt starts from an empty directory.
attempt() {
    rm -rf "$rootfs" && mkdir -p "$rootfs" &&
        debootstrap --variant=minbase "$SUITE" "$rootfs" >/tmp/isoremesh-debootstrap.log 2>&1
}
if ! retry attempt; then
    say "debootstrap failed (log: /tmp/isoremesh-debootstrap.log); the container test will fail to build"
    exit 0
fi
# Trim what a container never uses, as the official slim image does.
rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/* \
    "$rootfs"/usr/share/doc/* "$rootfs"/usr/share/man/* "$rootfs"/usr/share/locale/*
if tar -C "$rootfs" -c . | podman import - "$BASE_IMAGE" >/dev/null; then
    say "imported $BASE_IMAGE"
else
    say "podman import failed"
fi
exit 0
