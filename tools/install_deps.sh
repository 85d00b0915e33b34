#!/usr/bin/env bash
# Installs mlsdeform's build and test dependencies from Debian 12 (bookworm) or Debian 13 (trixie) packages,
# chosen by /etc/os-release. Idempotent, and quiet when everything is already there. Uses sudo when not root.
# Arguments add optional parts: `bench` (CGAL, for bench_quality's reference ARAP), `blender` (Blender), `web`
# (emscripten and Chromium from Debian, and the page's npm packages into web/node_modules from
# web/package-lock.json: docs/web.md), `clang19` (Debian 12: clang 19 beside the default clang 14, for a clang
# build: CXX=clang++-19; Debian 13's default clang is 19 already), `arm64` (the ARM64 cross build,
# cmake/aarch64-linux-gnu.cmake: Debian's cross g++, the arm64 libraries by multiarch, and qemu-aarch64 10:
# Debian 13's qemu-user, which on Debian 12 is unpacked into /opt/qemu-trixie/bin).
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
arm64=0
for arg in "$@"; do
  case "$arg" in
    arm64)
      # The arm64 -dev packages by multiarch (dpkg --add-architecture below); xsimd's carries its CMake package
      # for the target's library directory, Eigen, CLI11 and nlohmann-json are architecture-independent.
      arm64=1
      packages+=(g++-aarch64-linux-gnu libtbb-dev:arm64 libxsimd-dev:arm64 zlib1g-dev:arm64)
      # qemu 10 (tools/insn_per_fit.sh's instruction counts are its); Debian 12's 7.2 would run the tests too.
      [ "$codename" = trixie ] && packages+=(qemu-user)
      ;;
    bench) packages+=(libcgal-dev) ;;
    clang19) [ "$codename" = trixie ] || packages+=(clang-19 libclang-rt-19-dev) ;;
    blender) packages+=(blender) ;;
    web)
      web=1
      packages+=(emscripten node-acorn chromium)
      command -v npm >/dev/null || [[ " ${packages[*]} " == *" npm "* ]] || packages+=(nodejs npm)
      ;;
    judge)
      judge=1
      command -v npm >/dev/null || [[ " ${packages[*]} " == *" npm "* ]] || packages+=(nodejs npm)
      ;;
    *) echo "install_deps: unknown part '$arg' (bench, blender, web, judge, clang19, arm64)" >&2; exit 2 ;;
  esac
done
# The page's packages (three, Spark; puppeteer-core, which drives the Debian Chromium and downloads no browser),
# pinned by web/package-lock.json, into web/node_modules only.
web_npm() {
  [ "$web" = 1 ] || return 0
  local root
  root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
  if [ ! -d "$root/web/node_modules/three" ] || [ ! -d "$root/web/node_modules/puppeteer-core" ] ||
    [ ! -d "$root/web/node_modules/@sparkjsdev/spark" ] ||
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
# Debian 12 (arm64): Debian 13's static qemu-aarch64 and qemu-x86_64 (qemu-user 10.0, whose binaries are static)
# unpacked into /opt/qemu-trixie/bin, where cmake/aarch64-linux-gnu.cmake looks first. The package comes from
# Debian's trixie suite through apt with a private source list and state, so the host's apt sources stay as they
# are; it is checked with the archive keys of Debian 12's debian-archive-keyring, which include Debian 13's.
qemu_dir=/opt/qemu-trixie/bin
arm64_qemu() {
  [ "$arm64" = 1 ] && [ "$codename" = bookworm ] || return 0
  [ -x "$qemu_dir/qemu-aarch64" ] && [ -x "$qemu_dir/qemu-x86_64" ] && return 0
  echo "install_deps: Debian 13's qemu-user into $qemu_dir" >&2
  local tmp opts
  tmp=$(mktemp -d)
  mkdir -p "$tmp/lists/partial" "$tmp/cache/archives/partial" "$tmp/deb"
  echo "deb [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] ${DEBIAN_MIRROR:-http://deb.debian.org/debian}" \
    "trixie main" >"$tmp/sources.list"
  opts=(-o "Dir::Etc::SourceList=$tmp/sources.list" -o Dir::Etc::SourceParts=/dev/null
    -o "Dir::State::Lists=$tmp/lists" -o "Dir::Cache=$tmp/cache" -o APT::Architectures::=amd64
    -o Debug::NoLocking=1 -o APT::Sandbox::User=root)
  $sudo apt-get "${opts[@]}" update -qq
  (cd "$tmp/deb" && $sudo apt-get "${opts[@]}" download qemu-user >/dev/null 2>&1)
  $sudo dpkg-deb -x "$tmp"/deb/qemu-user_*.deb "$tmp/root"
  $sudo mkdir -p "$qemu_dir"
  $sudo cp "$tmp/root/usr/bin/qemu-aarch64" "$tmp/root/usr/bin/qemu-x86_64" "$qemu_dir/"
  $sudo rm -rf "$tmp"
  "$qemu_dir/qemu-aarch64" --version | head -n 1 >&2
}
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
if [ "$arm64" = 1 ] && ! dpkg --print-foreign-architectures | grep -qx arm64; then
  echo "install_deps: dpkg --add-architecture arm64" >&2
  $sudo dpkg --add-architecture arm64
  $sudo apt-get update -qq
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  web_npm
  judge_npm
  arm64_qemu
  exit 0
fi
echo "install_deps: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
web_npm
judge_npm
arm64_qemu
