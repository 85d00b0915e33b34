#!/usr/bin/env bash
# One check of the page in headless Chromium (web/tests/browser.mjs), for the native build's ctest label `web`
# (tests/web.cmake). Usage: run_browser_test.sh SITE CHECK [PROGRAM]; PROGRAM is build/tools/mlsdeform, for
# `compare` and `splat_pose`. Exit 77 (skipped) where emscripten or Chromium is not installed.
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
splats() { node "$root/web/tests/browser_splats.mjs" "$site" "$@"; }
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
  malformed)
    # The message `mlsdeform deform` prints for the malformed file (run beside it, so that it names the file
    # as the page does), which the page must show word for word.
    printf 'v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n' >"$tmp/broken.obj"
    if [ -n "$program" ]; then
      (cd "$tmp" && ! "$program" deform -q -m broken.obj -H "$root/data/human_bend.json" -o out.obj 2>message.txt)
      sed -i 's/^mlsdeform: error: //' "$tmp/message.txt"
    fi
    run malformed "$tmp"
    ;;
  formats)
    # The human's first frame as the program writes it in each format (PLY binary, OFF also gzip-compressed):
    # the page reads the same floats from each (its OBJ reader is the reference, the three are the program's).
    [ -n "$program" ] || { echo "skipped: formats needs the program (MLSDEFORM_BUILD_TOOLS)"; exit 77; }
    for f in obj off ply; do
      "$program" deform -q -m "$root/data/human_man.obj" -H "$root/data/human_bend.json" -o "$tmp/human.$f"
      mv "$tmp/human_0000.$f" "$tmp/human.$f"
      rm -f "$tmp"/human_00*."$f"
    done
    gzip -k "$tmp/human.off"
    run formats "$tmp"
    ;;
  screenshot) run screenshot "${WEB_SCREENSHOT:-$tmp/page.png}" ;;
  splat_pose)
    # A splat scene posed on the page (handles on splats, moved), exported as 3DGS PLY and SPZ: the program,
    # given the scene and the page's handles file, writes the page's PLY byte for byte (the SSE4.2 kernels, as
    # for `compare`); the SPZ read back is the PLY within SPZ's bounds (browser_splats.mjs).
    splats pose "$tmp"
    if [ -n "$program" ]; then
      MLSDEFORM_ISA=sse4_2 "$program" deform -q -m "$tmp/scene.ply" -H "$tmp/handles.json" -o "$tmp/program.ply"
      if ! cmp "$tmp/page.ply" "$tmp/program.ply"; then
        echo "FAILED: the page's PLY and \`mlsdeform deform\`'s differ" >&2
        exit 1
      fi
      echo "page.ply and mlsdeform deform's program.ply: bitwise equal ($(wc -c <"$tmp/page.ply") bytes)"
      for t in similarity affine; do
        MLSDEFORM_ISA=sse4_2 "$program" deform -q -t $t -m "$tmp/scene.ply" -H "$tmp/handles.json" -o "$tmp/program_$t.ply"
        if ! cmp "$tmp/page_$t.ply" "$tmp/program_$t.ply"; then
          echo "FAILED: the page's PLY and \`mlsdeform deform -t $t\`'s differ" >&2
          exit 1
        fi
        echo "page_$t.ply and mlsdeform deform -t $t's: bitwise equal"
      done
      # The same pose as the program writes it in the compact formats, opened by the page.
      for f in compressed.ply spz; do
        "$program" deform -q -m "$tmp/scene.ply" -H "$tmp/handles.json" -o "$tmp/program.$f" 2>/dev/null
      done
      splats formats "$tmp"
    fi
    ;;
  splat_screenshot) splats screenshot "${WEB_SCREENSHOT:-$tmp/splats.png}" ;;
  splat_hostile) splats hostile ;;
  *) run "$check" ;;
esac
