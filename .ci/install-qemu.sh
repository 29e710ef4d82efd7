#!/usr/bin/env bash
# Install `qemu-system-arm` >= 10 from Debian <codename>-backports.
#
# The machine's apt sources do not list backports, and bookworm's own
# qemu-system-arm (7.2) would remove the backports `qemu-utils` that is already
# installed. So this script builds a *private* apt source list: a copy of the
# system's `debian.sources` plus a `<codename>-backports` stanza whose `URIs:`
# value is read from that copy (no mirror host is written here), and passes it
# to apt with `-o Dir::Etc::SourceParts=... -o Dir::Etc::SourceList=...`.
# `/etc/apt` is left untouched.
#
# Idempotent: exits at once when `qemu-system-arm` >= 10 is already on PATH.
# Needs root (CI and developer machines run as root).
set -euo pipefail

MIN_MAJOR=10

# Print the major version of the installed qemu-system-arm, or nothing.
qemu_major() {
    command -v qemu-system-arm >/dev/null 2>&1 || return 0
    qemu-system-arm --version | sed -n 's/^QEMU emulator version \([0-9]*\)\..*/\1/p'
}

major="$(qemu_major)"
if [[ -n "$major" && "$major" -ge "$MIN_MAJOR" ]]; then
    echo "install-qemu: $(qemu-system-arm --version | head -n1) already installed"
    exit 0
fi

system_sources=/etc/apt/sources.list.d/debian.sources
if [[ ! -r "$system_sources" ]]; then
    echo "install-qemu: $system_sources not found; cannot derive the mirror" >&2
    exit 1
fi

# shellcheck disable=SC1091
codename="$(. /etc/os-release && echo "${VERSION_CODENAME:?}")"

# The URIs value of the stanza that lists the release itself (Suites: <codename>),
# not the security one.
uris="$(awk -v suite="$codename" '
    BEGIN { RS = ""; FS = "\n" }
    {
        u = ""; hit = 0
        for (i = 1; i <= NF; i++) {
            if ($i ~ /^URIs:/) { u = $i; sub(/^URIs:[ \t]*/, "", u) }
            if ($i ~ /^Suites:/) {
                n = split($i, w, /[ \t]+/)
                for (j = 2; j <= n; j++) if (w[j] == suite) hit = 1
            }
        }
        if (hit && u != "") { print u; exit }
    }' "$system_sources")"
if [[ -z "$uris" ]]; then
    echo "install-qemu: no stanza with Suites: $codename in $system_sources" >&2
    exit 1
fi
keyring="$(awk -v suite="$codename" '
    BEGIN { RS = ""; FS = "\n" }
    $0 ~ ("Suites:.*" suite) {
        for (i = 1; i <= NF; i++) if ($i ~ /^Signed-By:/) { k = $i; sub(/^Signed-By:[ \t]*/, "", k); print k; exit }
    }' "$system_sources")"

private="$(mktemp -d)"
trap 'rm -rf "$private"' EXIT
mkdir -p "$private/sources.list.d"
cp "$system_sources" "$private/sources.list.d/debian.sources"
{
    echo "Types: deb"
    echo "URIs: $uris"
    echo "Suites: $codename-backports"
    echo "Components: main"
    if [[ -n "$keyring" ]]; then echo "Signed-By: $keyring"; fi
} >"$private/sources.list.d/backports.sources"

apt_opts=(
    -o "Dir::Etc::SourceParts=$private/sources.list.d"
    -o "Dir::Etc::SourceList=/dev/null"
)
echo "install-qemu: qemu-system-arm from $codename-backports"
export DEBIAN_FRONTEND=noninteractive
apt-get "${apt_opts[@]}" -qq update
apt-get "${apt_opts[@]}" -y -qq --no-install-recommends \
    -t "$codename-backports" install qemu-system-arm

major="$(qemu_major)"
if [[ -z "$major" || "$major" -lt "$MIN_MAJOR" ]]; then
    echo "install-qemu: got '$(qemu-system-arm --version | head -n1)', need >= $MIN_MAJOR" >&2
    exit 1
fi
echo "install-qemu: $(qemu-system-arm --version | head -n1)"
