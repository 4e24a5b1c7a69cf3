#!/usr/bin/env bash
# Installs what the project needs and is missing: Debian packages (apt-get,
# with a lock timeout and one retry) and the Python packages into .venv.
# Quiet and quick when everything is there already.
# `tools/install-deps.sh fuzz` installs only what `make fuzz` needs besides:
# clang and its sanitizer/libFuzzer runtimes (never installed by `make test`).
set -euo pipefail
cd "$(dirname "$0")/.."

if [ "${1:-}" = fuzz ]; then
    debs=(clang libclang-rt-14-dev)
else
    debs=(build-essential pkg-config libhdf5-dev libhdf5-openmpi-dev hdf5-tools libsundials-dev
          libopenmpi-dev openmpi-bin libcunit1-dev libcyaml-dev libyaml-dev libxml2-dev libzip-dev
          python3-venv python3-pip)
fi
missing=()
for p in "${debs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    echo "install-deps: installing ${missing[*]}"
    apt_get() {
        $sudo env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=300 "$@"
    }
    { apt_get update -q && apt_get install -y -q --no-install-recommends "${missing[@]}"; } ||
        { sleep 10; apt_get update -q && apt_get install -y -q --no-install-recommends "${missing[@]}"; }
fi

[ "${1:-}" = fuzz ] && exit 0

stamp=.venv/.requirements-installed
if [ ! -f "$stamp" ] || ! cmp -s tools/requirements.txt "$stamp"; then
    echo "install-deps: creating the Python environment in .venv"
    python3 -m venv .venv
    .venv/bin/pip install -q --upgrade pip
    .venv/bin/pip install -q -r tools/requirements.txt || { sleep 10; .venv/bin/pip install -q -r tools/requirements.txt; }
    cp tools/requirements.txt "$stamp"
fi
