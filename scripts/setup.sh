#!/usr/bin/env bash
# Installs everything cdshear needs from Debian's packages and builds it in ./build (Release).
# Idempotent: packages already present are skipped by apt-get, the build is incremental.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake ninja-build libcli11-dev libtomlplusplus-dev nlohmann-json3-dev
          libfmt-dev librandom123-dev libgtest-dev libhdf5-dev zlib1g-dev liblapacke-dev
          libsuitesparse-dev
          clang libclang-rt-14-dev openmpi-bin libopenmpi-dev
          python3-numpy python3-scipy python3-matplotlib python3-h5py
          python3-venv python3-pip python3-setuptools python3-wheel
          chromium-headless-shell)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"
fi

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)"
