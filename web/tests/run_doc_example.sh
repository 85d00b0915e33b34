#!/usr/bin/env bash
# Runs the JavaScript example of docs/web.md (the ```js block after its "<!-- example" line) under Node, from
# build-web/site/ so that its `import './mlsdeform.js'` resolves. Exit 77 (skipped) without emscripten.
set -euo pipefail
site=$1
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
if ! command -v emcc >/dev/null; then
  echo "skipped: emscripten is not installed (tools/install_deps.sh web installs it)"
  exit 77
fi
[ -f "$site/mlsdeform.js" ] || { echo "$site is missing: run tools/dev.sh web first" >&2; exit 1; }
example="$site/doc_example.mjs"
trap 'rm -f "$example"' EXIT
awk '/^<!-- example/ {on = 1; next} on && /^```js/ {copy = 1; next} copy && /^```/ {exit} copy' \
  "$root/docs/web.md" > "$example"
[ -s "$example" ] || { echo "docs/web.md has no example block" >&2; exit 1; }
node --no-experimental-fetch "$example"
