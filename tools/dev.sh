#!/usr/bin/env bash
# The README's two commands:
#   tools/dev.sh demo   install what is missing, build (Release), run `mlsdeform demo`
#   tools/dev.sh test   install what is missing, build, run the whole test suite through ctest, then the
#                       C++ tests and the program's again under AddressSanitizer + UndefinedBehaviorSanitizer
#                       with every assertion on, then the other platforms' stages (HACKING.md): Debian 13 with
#                       clang 19, numpy 2 and Blender 4.3 in a debootstrap root (tools/trixie.sh ci; root or
#                       sudo), and ARM64 cross-built and tested under qemu (`arm64` below); MLSDEFORM_PLATFORMS=0
#                       skips those two
#   tools/dev.sh python install what is missing, build (Release), install the Python package into the venv .venv/
#                       (made if missing; editable: it loads the module of build/, so a rebuild is picked up)
#                       and run the Python tests against it
#   tools/dev.sh blender  install what is missing (Blender too), build build/mlsdeform_blender.zip (the add-on with
#                       the compiled module inside, Blender 3.4 to 4.1) and build/mlsdeform_blender_extension.zip
#                       (the Blender 4.2+ extension, the module as a bundled wheel), and run their headless tests
#   tools/dev.sh web    install what is missing (emscripten, Chromium, the page's npm packages), build build-web/:
#                       the library in WebAssembly, its tests under Node, and the page in build-web/site/
#                       (docs/web.md); `tools/dev.sh web --serve [PORT]` then serves the page on localhost
#   tools/dev.sh format rewrite every C++ file as .clang-format says (Debian 12's clang-format 14) and every Python
#                       file as black says (Debian 12's black 23.1, pyproject.toml); CI checks both
#   tools/dev.sh arm64  install what is missing (the cross g++, the arm64 libraries, qemu-aarch64), cross-build
#                       build-arm64/ for aarch64 (cmake/aarch64-linux-gnu.cmake): the library, the program and the
#                       test programs of the label `cross` only, and run that label under qemu (docs/arm64.md);
#                       it ends by printing the program's own report of its SIMD table (neon)
# Extra arguments after `demo` go to the demo.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
jobs=$(nproc 2>/dev/null || echo 2)
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
case "${1:-}" in
  test)
    if [ "${MLSDEFORM_PLATFORMS:-1}" = 0 ]; then
      bash tools/install_deps.sh blender web judge
    else
      bash tools/install_deps.sh blender web judge arm64
    fi
    ;;
  blender) bash tools/install_deps.sh blender ;;
  web) bash tools/install_deps.sh web ;;
  arm64) bash tools/install_deps.sh arm64 ;;
  *) bash tools/install_deps.sh ;;
esac
# The project's own builds link CHOLMOD for the supernodal ARAP factorisation (GPL-2+: the CMake option is
# off by default, see docs/api.md); the sanitizer build leaves it off, so CI tests both factorisations.
build() {  # build DIR [cmake args...]; BUILD_TARGET=NAME builds that target (and what it needs) alone
  local dir=$1; shift
  cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DMLSDEFORM_CHOLMOD=ON "$@" >/dev/null
  cmake --build "$dir" -j "$jobs" ${BUILD_TARGET:+--target "$BUILD_TARGET"}
}
# The WebAssembly build (docs/web.md): emscripten's cmake wrapper; NODE_PATH lets emcc's link step find
# Debian's acorn when the node on PATH is not Debian's.
build_web() {
  export NODE_PATH=/usr/share/nodejs
  emcmake cmake -S . -B build-web -DCMAKE_BUILD_TYPE=Release -DMLSDEFORM_WERROR=ON >/dev/null
  cmake --build build-web -j "$jobs"
}
# The ARM64 stage (docs/arm64.md): the targets the label `cross` runs (tests/CMakeLists.txt:
# MLSDEFORM_CROSS_LABELLED and the program), not the whole cross set, whose other programs (the deformer session,
# segment, allocation tests, and the deformer's tests again under each forced ISA) take minutes more under the
# emulator; it ends with the program's own report of its table, which must be NEON.
arm64_stage() {
  cmake -S . -B build-arm64 --toolchain cmake/aarch64-linux-gnu.cmake -DCMAKE_BUILD_TYPE=Release \
    -DMLSDEFORM_WERROR=ON >/dev/null
  local targets
  targets=$(sed -n 's/^MLSDEFORM_CROSS_LABELLED:STRING=//p' build-arm64/CMakeCache.txt | tr ';' ' ')
  # shellcheck disable=SC2086 # one target per word
  cmake --build build-arm64 -j "$jobs" --target mlsdeform $targets
  ctest --test-dir build-arm64 --output-on-failure -j "$jobs" -L cross
  grep -m 1 -o 'deformer: .* backend' build-arm64/Testing/Temporary/LastTest.log
}
case "${1:-}" in
  web)
    build_web
    echo "site: $root/build-web/site/ (tools/dev.sh web --serve to open it)"
    if [ "${2:-}" = --serve ]; then
      port=${3:-8000}
      echo "serving http://localhost:$port/ (Ctrl-C stops)"
      exec /usr/bin/python3 -m http.server --bind 127.0.0.1 --directory build-web/site "$port"
    fi
    ;;
  demo)
    shift
    # The program alone (the library and tools/cli/): not the tests, benchmarks, fuzzers and Python module that
    # `test` builds in the same folder.
    BUILD_TARGET=mlsdeform build build
    exec build/tools/mlsdeform demo "$@"
    ;;
  python)
    build build -DMLSDEFORM_BUILD_PYTHON=ON
    # A venv that sees Debian's numpy and pytest; nothing is written outside the checkout.
    [ -x .venv/bin/python ] || /usr/bin/python3 -m venv --system-site-packages .venv
    MLSDEFORM_BUILD_DIR="$root/build" .venv/bin/python -m pip install -q --no-build-isolation -e .
    cd /tmp
    "$root/.venv/bin/python" -c "import mlsdeform; print('mlsdeform', mlsdeform.__version__, 'from', mlsdeform.__file__)"
    echo "use it: . $root/.venv/bin/activate (python, and the mlsdeform program)"
    MLSDEFORM_PY_REFERENCE="$root/build/python/mlsdeform_py_reference" \
      exec "$root/.venv/bin/python" -m pytest -q -p no:cacheprovider "$root/python/tests"
    ;;
  blender)
    build build -DMLSDEFORM_BUILD_PYTHON=ON
    ctest --test-dir build --output-on-failure -R 'blender_(addon|extension)'
    echo "add-on (Blender 3.4 to 4.1): $root/build/mlsdeform_blender.zip (Preferences > Add-ons > Install...)"
    echo "extension (Blender 4.2+): $root/build/mlsdeform_blender_extension.zip (Preferences > Get Extensions >" \
      "Install from Disk...)"
    ;;
  format)
    find core kernels tests bench tools python web/src \( -name '*.cpp' -o -name '*.hpp' -o -name '*.inc' -o -name '*.h' \) \
      -print0 | xargs -0 clang-format-14 -i
    black --quiet .  # pyproject.toml's settings; the files git would take (.gitignore)
    ;;
  test)
    # The other platforms' stages run last, but the Debian 13 root's download and set-up (network and disk, a few
    # minutes) goes on in the background meanwhile; its log is build-trixie/setup.log.
    platforms=${MLSDEFORM_PLATFORMS:-1}
    trixie_setup=""
    if [ "$platforms" != 0 ] && [ "$(. /etc/os-release && echo "$VERSION_CODENAME")" != trixie ]; then
      mkdir -p build-trixie
      $sudo bash tools/trixie.sh setup blender >build-trixie/setup.log 2>&1 &
      trixie_setup=$!
    fi
    build_web  # before build/: its ctest label `web` runs the WebAssembly tests and the browser tests
    build build -DMLSDEFORM_WERROR=ON
    ctest --test-dir build --output-on-failure -j "$jobs"
    # Sanitizers and assertions in one build: the C++ tests, the program and its tests under AddressSanitizer +
    # UndefinedBehaviorSanitizer, with every assertion on (assert, Eigen's eigen_assert, oneTBB's TBB_USE_DEBUG,
    # which TBB::tbb's CMake target defines in Debug, libstdc++'s _GLIBCXX_ASSERTIONS). -O1 drops no assertion and
    # no sanitizer check, keeps Eigen's and xsimd's inline templates from running as calls, and compiles in about
    # half the time -O3 takes under the sanitizers (the kernels are -O3 in every build: kernels/CMakeLists.txt).
    # No benchmarks or Python module (an extension would need the sanitizers' runtime preloaded into python3):
    # they drive the same library through its public API, which the C++ tests cover, and run in the Release build
    # above. CHOLMOD off: the library's own factorisation is tested here, CHOLMOD's above.
    build build-asan -DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-O1 -D_GLIBCXX_ASSERTIONS" \
      -DMLSDEFORM_SANITIZE=ON -DMLSDEFORM_BUILD_BENCH=OFF -DMLSDEFORM_WERROR=ON -DMLSDEFORM_CHOLMOD=OFF
    ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
      ctest --test-dir build-asan --output-on-failure -j "$jobs" -LE no_sanitizer
    if [ "$platforms" = 0 ]; then
      echo "dev.sh test: MLSDEFORM_PLATFORMS=0: the Debian 13 and ARM64 stages are skipped" >&2
      exit 0
    fi
    arm64_stage
    # Debian 13: clang 19, xsimd 13, Catch2 3, Python 3.13 with numpy 2 and pybind11 2.13, Blender 4.3. On a
    # Debian 13 host the builds above were that platform already (with its g++).
    if [ -n "$trixie_setup" ]; then
      if ! wait "$trixie_setup"; then
        tail -n 30 build-trixie/setup.log >&2
        echo "dev.sh test: the Debian 13 root's set-up failed (build-trixie/setup.log)" >&2
        exit 1
      fi
      $sudo bash tools/trixie.sh ci
    fi
    ;;
  arm64) arm64_stage ;;
  *)
    echo "usage: tools/dev.sh demo [demo options] | test | python | blender | web [--serve [PORT]] | format | arm64" >&2
    exit 2
    ;;
esac
