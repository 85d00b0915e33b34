#!/usr/bin/env bash
# Runs one of the library's tests compiled to WebAssembly (build-web/web/web_<name>.js), or a test of the
# JavaScript API (web/tests/api.mjs, with its arguments), under Node, for the
# native build's ctest label `web` (tests/web.cmake). Exit 77 (skipped) where emscripten is not installed.
set -euo pipefail
js=$1
shift
if ! command -v emcc >/dev/null; then
  echo "skipped: emscripten is not installed (tools/install_deps.sh web installs it)"
  exit 77
fi
if [ ! -f "$js" ] && [[ "$js" == */web_test_* ]] && [ ! -f /usr/include/catch2/catch.hpp ]; then
  echo "skipped: no Catch2 2 single header to compile the WebAssembly C++ tests with (Debian 13: web/cmake/tests.cmake)"
  exit 77
fi
if [ ! -f "$js" ]; then
  echo "$js is missing: build the WebAssembly tests first (tools/dev.sh web)" >&2
  exit 1
fi
exec node --no-experimental-fetch "$js" "$@"
