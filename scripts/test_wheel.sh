#!/usr/bin/env bash
# The Python package as a user installs it (docs/python.md, "Installing"): `pip wheel .` through
# the in-tree build backend (pyproject.toml; offline: --no-index), packing an already built tree;
# the wheel installed into a fresh venv (with the system's NumPy); then, from a folder outside the
# source and build trees and without PYTHONPATH, python/packaging_test/check_installed.py: the
# package and its plugins load from the venv, and it renders, enhances and scores.
# Usage: scripts/test_wheel.sh --build DIR --python PYTHON
# Exits 77 (CTest: skipped) when the interpreter has no venv or pip module (python3-venv,
# python3-pip; scripts/install_deps.sh --test installs them).
set -euo pipefail
src="$(cd "$(dirname "$0")/.." && pwd)"
build="" python=""
while (($#)); do
  case "$1" in
    --build) build="$(realpath "$2")"; shift 2 ;;
    --python) python="$2"; shift 2 ;;
    *) echo "test_wheel.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
[[ -n "$build" && -n "$python" ]] || { echo "usage: $0 --build DIR --python PYTHON" >&2; exit 2; }
for module in venv pip ensurepip; do
  if ! "$python" -c "import $module" 2>/dev/null; then
    echo "skipped: $python has no '$module' module (apt-get install python3-venv python3-pip)"
    exit 77
  fi
done
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
TURBID_WHEEL_BUILD_DIR="$build" "$python" -m pip wheel --no-deps --no-index --quiet \
  -w "$work/wheels" "$src"
wheels=("$work"/wheels/turbid-*.whl)
[[ ${#wheels[@]} == 1 && -f "${wheels[0]}" ]] || { echo "no single turbid wheel built" >&2; exit 1; }
echo "built $(basename "${wheels[0]}") ($(du -k "${wheels[0]}" | cut -f1) KiB)"
"$python" -m venv --system-site-packages "$work/venv"
"$work/venv/bin/python" -m pip install --no-deps --no-index --quiet "${wheels[0]}"
mkdir "$work/run"
cd "$work/run"
env -u PYTHONPATH -u TURBID_CLI "$work/venv/bin/python" "$src/python/packaging_test/check_installed.py" \
  "$work/venv"
