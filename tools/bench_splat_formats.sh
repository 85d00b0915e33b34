#!/usr/bin/env bash
# The splat formats' speed (docs/splats.md "Speed"): 10^6 splats of SH degree 3 read, deformed and written by the
# program, beside the same centres as a bare point cloud, in each format; and splat-transform (the tests' judge,
# tools/install_deps.sh judge) reading and writing the same SPZ file. One run each, wall clock, with the load
# average before and after: take the ratios.
#
#   tools/bench_splat_formats.sh [BUILD_DIR] [FOLDER]     (defaults: build, a temporary folder; ~1.5 GB there)
#
# The read and write columns are bench_splat_files' (the program's read_mesh and write_mesh); the deform column
# is the program's own report (set-up, MLS frames, splats turned) of `mlsdeform deform`; the whole run is timed
# as the user sees it.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
work=${2:-$(mktemp -d)}
judge=$root/tests/splat_judge/node_modules/.bin/splat-transform
echo "cpu: $(lscpu | sed -n 's/^Model name: *//p') ($(nproc) cores); load before: $(cut -d' ' -f1-3 /proc/loadavg)"
"$build/bench/bench_splat_files" --dir="$work" --benchmark_format=console 2>/dev/null |
  grep -E '^(read|write)/' | awk '{printf "%-34s %8s ms\n", $1, $2}'
seconds() { /usr/bin/time -f %e "$@" 2>&1 >/dev/null | tail -1; }
for input in big.ply points.ply big.spz big.compressed.ply; do
  out=out_${input}
  log=$("$build/tools/mlsdeform" deform -m "$work/$input" -H "$work/big.json" -o "$work/$out" -f 2>&1)
  wall=$(seconds "$build/tools/mlsdeform" deform -m "$work/$input" -H "$work/big.json" -o "$work/$out" -f -q)
  setup=$(sed -n 's/.*set-up \([0-9.]*\) ms.*/\1/p' <<<"$log")
  frames=$(sed -n 's/.*deformed in \([0-9.]*\) ms.*/\1/p' <<<"$log")
  turned=$(sed -n 's/^splats turned in \([0-9.]*\) ms.*/\1/p' <<<"$log")
  printf "program %-20s wall %6s s; set-up %s ms, MLS %s ms, splats turned %s ms\n" "$input" "$wall" "$setup" \
    "$frames" "${turned:-0}"
done
if [ -x "$judge" ] && command -v node >/dev/null; then
  t_start=$(seconds node "$judge" --version)
  t_ply=$(seconds node "$judge" -q -w "$work/big.ply" null)
  t_write=$(seconds node "$judge" -q -w "$work/big.ply" "$work/judge.spz")
  t_read=$(seconds node "$judge" -q -w "$work/big.spz" null)
  echo "splat-transform: start ${t_start} s; big.ply read ${t_ply} s; big.ply -> spz ${t_write} s" \
    "(spz write = the difference); big.spz read ${t_read} s (start included)"
else
  echo "splat-transform not installed (tools/install_deps.sh judge): its row skipped"
fi
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
[ -n "${2:-}" ] || rm -rf "$work"
