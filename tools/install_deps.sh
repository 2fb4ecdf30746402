#!/usr/bin/env bash
# Installs the Debian 12 packages veil needs to build, test and benchmark, skipping the
# ones already present (so it is quick, and needs no network, on a prepared machine).
set -euo pipefail
packages=(
  build-essential cmake ninja-build pkg-config
  libembree-dev libcgal-dev libopenmesh-dev libopenexr-dev libglm-dev libtbb-dev
  libtomlplusplus-dev libcli11-dev nlohmann-json3-dev libcairo2-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libjs-three chromium
  pybind11-dev python3-dev python3-numpy python3-matplotlib python3-pytest
  libopenmpi-dev openmpi-bin
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "install_deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -q
apt-get install -y -q --no-install-recommends "${missing[@]}"
