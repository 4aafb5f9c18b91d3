#!/usr/bin/env bash
# Installs turbid's build and test dependencies from Debian 12 packages, only what is missing.
# Usage: scripts/install_deps.sh [--test] [--slurm]
#   --test   adds what the test suite needs: chromium, python3-torch for the DataLoader test of
#            the Python package, python3-h5py to write NYU-layout HDF5 files independently of our
#            reader, python3-pip + python3-venv for the wheel test (scripts/test_wheel.sh: pip install
#            into a fresh venv), slurm-wlm + munge for the single-node Slurm test, and clang-14 with its
#            sanitizer runtimes and libFuzzer for the hardening pass (build-san, fuzz/)
#   --slurm  adds only slurm-wlm and munge (scripts/slurm/test_local.sh, ctest slurm/local_array;
#            the test skips, saying why, when they are missing or it cannot start the daemons)
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libopencv-dev libopencv-contrib-dev libeigen3-dev libopenexr-dev libopenimageio-dev
  libpng-dev libjpeg62-turbo-dev zlib1g-dev
  nlohmann-json3-dev libcli11-dev libtbb-dev libhdf5-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  gnuplot-nox
  python3-pybind11 python3-numpy python3-pytest
)
for flag in "$@"; do
  case "$flag" in
    --test) packages+=(chromium python3-torch python3-h5py python3-pip python3-venv slurm-wlm munge clang-14 libclang-rt-14-dev
                       libfuzzer-14-dev) ;;
    --slurm) packages+=(slurm-wlm munge) ;;
    *) echo "usage: $0 [--test] [--slurm]" >&2; exit 2 ;;
  esac
done

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
