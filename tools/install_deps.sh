#!/usr/bin/env bash
# Installs mlsdeform's build and test dependencies from Debian 12 packages. Idempotent, and quiet when
# everything is already there. Uses sudo when not root. With the argument `blender`, Blender too.
set -euo pipefail
packages=(cmake g++ make pkg-config
  libtbb-dev libxsimd-dev libeigen3-dev libbenchmark-dev catch2            # the library, tests, benchmarks
  libsuitesparse-dev libopenblas0-pthread                                 # CHOLMOD, its BLAS (MLSDEFORM_CHOLMOD)
  nlohmann-json3-dev libcli11-dev zlib1g-dev                               # the command-line tool
  python3 python3-matplotlib                                              # figures and benchmark plots
  python3-dev python3-numpy python3-pytest pybind11-dev python3-pybind11  # the Python package (python/)
  python3-pip python3-venv python3-setuptools python3-wheel python3-build  # ... as a wheel (pyproject.toml)
  python3-dask python3-distributed                                        # mlsdeform.dask and its tests
  clang libclang-rt-14-dev                                                # the libFuzzer targets
  clang-format                                                            # the format check (tests/format.cmake)
  black flake8)                                                           # the Python checks (tests/python_style.cmake)
# `install_deps.sh blender` adds Debian's Blender 3.4 for the add-on's headless test (tools/blender/).
[ "${1:-}" = blender ] && packages+=(blender)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "install_deps: installing ${missing[*]}" >&2
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
