#!/usr/bin/env bash
# One check of the page in headless Chromium (web/tests/browser.mjs), for the native build's ctest label `web`
# (tests/web.cmake). Usage: run_browser_test.sh SITE CHECK [PROGRAM]; PROGRAM is build/tools/mlsdeform, for
# `compare`. Exit 77 (skipped) where emscripten or Chromium is not installed.
set -euo pipefail
site=$1 check=$2 program=${3:-}
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
if ! command -v emcc >/dev/null; then
  echo "skipped: emscripten is not installed (tools/install_deps.sh web installs it)"
  exit 77
fi
if [ ! -x /usr/bin/chromium ]; then
  echo "skipped: Chromium is not installed (tools/install_deps.sh web installs it)"
  exit 77
fi
if [ ! -f "$site/index.html" ] || [ ! -d "$root/web/node_modules/puppeteer-core" ]; then
  echo "$site or web/node_modules is missing: run tools/dev.sh web first" >&2
  exit 1
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
run() { node "$root/web/tests/browser.mjs" "$site" "$@"; }
case "$check" in
  compare)
    # The first frame of the human bending, as the program writes it: on the SSE4.2 kernels (bitwise the
    # page's) and on the CPU's best ISA (within the bound of compare.mjs).
    MLSDEFORM_ISA=sse4_2 "$program" deform -q -m "$root/data/human_man.obj" -H "$root/data/human_bend.json" \
      -o "$tmp/sse4_2.obj"
    run compare "$tmp/sse4_2_0000.obj" exact
    "$program" deform -q -m "$root/data/human_man.obj" -H "$root/data/human_bend.json" -o "$tmp/best.obj"
    run compare "$tmp/best_0000.obj"
    ;;
  interact)
    # The pose made by the click and the drag, exported as OBJ and handles file: `mlsdeform deform` on that
    # handles file gives the same mesh (bitwise on the SSE4.2 kernels, as for `compare`).
    run interact "$tmp"
    if [ -n "$program" ]; then
      MLSDEFORM_ISA=sse4_2 "$program" deform -q -m "$root/data/human_man.obj" -H "$tmp/handles.json" -o "$tmp/program.obj"
      node "$root/web/tests/compare.mjs" "$tmp/page.obj" "$tmp/program.obj" "$root/data/human_man.obj" exact
    fi
    ;;
  screenshot) run screenshot "${WEB_SCREENSHOT:-$tmp/page.png}" ;;
  *) run "$check" ;;
esac
