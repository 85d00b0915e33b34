#!/usr/bin/env bash
# Installs mlsdeform's build and test dependencies from Debian 12 (bookworm) or Debian 13 (trixie) packages,
# chosen by /etc/os-release. Idempotent, and quiet when everything is already there. Uses sudo when not root.
# Arguments add optional parts: `bench` (CGAL, for bench_quality's reference ARAP), `blender` (Blender), `web`
# (emscripten and Chromium from Debian, and the page's npm packages into web/node_modules from
# web/package-lock.json: docs/web.md), `clang19` (Debian 12: clang 19 beside the default clang 14, for a clang
# build: CXX=clang++-19; Debian 13's default clang is 19 already).
set -euo pipefail
codename=$(. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}")
case "$codename" in
  bookworm) ;;
  trixie) ;;
  *)
    echo "install_deps: Debian 12 (bookworm) or 13 (trixie) expected; /etc/os-release says '${codename:-nothing}'." \
      "Installing the Debian 13 names." >&2
    codename=trixie
    ;;
esac
# What differs by release: the clang runtime that the libFuzzer targets link (clang's own version), and
# clang-format. The format test runs with clang-format 14 only (tests/format.cmake: other versions lay out
# differently), which Debian 13 no longer has: there it is skipped, saying so, and the rest runs.
if [ "$codename" = bookworm ]; then
  by_release=(libclang-rt-14-dev clang-format-14)
else
  by_release=(libclang-rt-19-dev clang-format)
fi
packages=(cmake g++ make pkg-config
  libtbb-dev libxsimd-dev libeigen3-dev libbenchmark-dev catch2            # the library, tests, benchmarks
  libsuitesparse-dev libopenblas0-pthread                                 # CHOLMOD, its BLAS (MLSDEFORM_CHOLMOD)
  nlohmann-json3-dev libcli11-dev zlib1g-dev libzstd-dev                   # the command-line tool (zstd: SPZ 4)
  python3 python3-matplotlib                                              # figures and benchmark plots
  python3-dev python3-numpy python3-pytest pybind11-dev python3-pybind11  # the Python package (python/)
  python3-pip python3-venv python3-setuptools python3-wheel python3-build  # ... as a wheel (pyproject.toml)
  python3-dask python3-distributed                                        # mlsdeform.dask and its tests
  clang "${by_release[@]}"                         # the libFuzzer targets, the format check (tests/format.cmake)
  black flake8)                                                           # the Python checks (tests/python_style.cmake)
# `install_deps.sh bench` adds CGAL 5.5 (header-only, GPL), which bench/CMakeLists.txt compiles into
# bench_quality alone for its reference ARAP rows (tools/bench_report.sh asks for it; without it those rows are
# skipped). Nothing else links it.
# `install_deps.sh blender` adds Debian's Blender (3.4 on Debian 12, 4.3 on 13) for the add-on's headless test
# (tools/blender/).
# `install_deps.sh web` adds emscripten (emcc 3.1.6; node-acorn for its link step) and Chromium (the browser
# tests drive it headless), and Node with npm where there is none.
# `install_deps.sh judge` adds Node with npm where there is none, and the independent splat converter the
# splat-format tests hold the program against (@playcanvas/splat-transform, pinned by
# tests/splat_judge/package-lock.json, into tests/splat_judge/node_modules only; docs/splats.md).
web=0
judge=0
for arg in "$@"; do
  case "$arg" in
    bench) packages+=(libcgal-dev) ;;
    clang19) [ "$codename" = trixie ] || packages+=(clang-19 libclang-rt-19-dev) ;;
    blender) packages+=(blender) ;;
    web)
      web=1
      packages+=(emscripten node-acorn chromium)
      command -v npm >/dev/null || packages+=(nodejs npm)
      ;;
    judge)
      judge=1
      command -v npm >/dev/null || packages+=(nodejs npm)
      ;;
    *) echo "install_deps: unknown part '$arg' (bench, blender, web, judge, clang19)" >&2; exit 2 ;;
  esac
done
# The page's packages (three; puppeteer-core, which drives the Debian Chromium and downloads no browser),
# pinned by web/package-lock.json, into web/node_modules only.
web_npm() {
  [ "$web" = 1 ] || return 0
  local root
  root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
  if [ ! -d "$root/web/node_modules/three" ] || [ ! -d "$root/web/node_modules/puppeteer-core" ] ||
    [ "$root/web/package-lock.json" -nt "$root/web/node_modules/.package-lock.json" ]; then
    echo "install_deps: npm ci in web/" >&2
    (cd "$root/web" && PUPPETEER_SKIP_DOWNLOAD=1 npm ci --no-audit --no-fund --ignore-scripts >/dev/null)
  fi
}
judge_npm() {
  [ "$judge" = 1 ] || return 0
  local dir
  dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/tests/splat_judge
  if [ ! -x "$dir/node_modules/.bin/splat-transform" ] ||
    [ "$dir/package-lock.json" -nt "$dir/node_modules/.package-lock.json" ]; then
    echo "install_deps: npm ci in tests/splat_judge/" >&2
    (cd "$dir" && npm ci --no-audit --no-fund --ignore-scripts >/dev/null)
  fi
}
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  web_npm
  judge_npm
  exit 0
fi
echo "install_deps: installing ${missing[*]}" >&2
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
web_npm
judge_npm
