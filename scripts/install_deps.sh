#!/usr/bin/env bash
# Installs turbid's build and test dependencies from Debian 12 packages, only what is missing.
# Usage: scripts/install_deps.sh [--test]   (--test adds what the test suite needs: chromium, and
# python3-torch for the DataLoader test of the Python package)
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libopencv-dev libopencv-contrib-dev libeigen3-dev libopenexr-dev libopenimageio-dev
  libpng-dev libjpeg62-turbo-dev zlib1g-dev
  nlohmann-json3-dev libcli11-dev libtbb-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  gnuplot-nox
  python3-pybind11 python3-numpy python3-pytest
)
if [[ "${1:-}" == "--test" ]]; then
  packages+=(chromium python3-torch)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  exit 0
fi

SUDO=""
if [[ "$(id -u)" != "0" ]]; then
  if command -v sudo >/dev/null; then SUDO="sudo"; else
    echo "install_deps: missing packages (${missing[*]}) and not root; install them or run as root" >&2
    exit 1
  fi
fi
echo "install_deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
