#!/usr/bin/env bash
# Installs the Debian packages eomgen needs, only those that are missing.
# Usage: scripts/setup.sh [extra-package ...]
set -euo pipefail
packages=(cmake g++ make libeigen3-dev libfmt-dev libgtest-dev libbenchmark-dev libqd-dev
          libboost-dev libtinyxml2-dev libopenmpi-dev openmpi-bin python3 python3-matplotlib
          python3-dev python3-numpy python3-pybind11 python3-pytest
          python3-venv  # pip install <checkout> into a venv (python/README.md); the interpreter test
          libmujoco-dev libmujoco-samples  # MJCF import (MuJoCo's compiler) and its tests' peer
          "$@")
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "eomgen: installing missing Debian packages: ${missing[*]}"
if [ "$(id -u)" = 0 ]; then sudo=(); elif command -v sudo >/dev/null; then sudo=(sudo); else
  echo "eomgen: not root and no sudo; please install: apt-get install ${missing[*]}" >&2; exit 1
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -qq
"${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
