#!/usr/bin/env bash
# Build the benchmarks (Release), run the whole suite with JSON output, and write docs/benchmarks.md and
# docs/plots/*.png (tools/bench_report.py). About 6-9 minutes on the 2-core development machine (bench_quality:
# about 2 of them: CGAL run to 500 iterations, ARAP set up on the 737,986-vertex spot_loop3).
#
#   tools/bench_report.sh            the full run (what docs/benchmarks.md shows)
#   tools/bench_report.sh --quick    a smoke test of the pipeline: 10^4 matrices, short timings; writes the
#                                    report into build-bench/bench-results/quick-docs instead of docs/
#
# Environment: BUILD_DIR (default build-bench), JOBS (default nproc). Installs what it needs with
# tools/install_deps.sh bench (the project's dependencies and CGAL, bench_quality's reference ARAP).
# Timings are only as good as the machine is quiet: the load average before and after is recorded.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
build=${BUILD_DIR:-$root/build-bench}
jobs=${JOBS:-$(nproc 2>/dev/null || echo 2)}
quick=0
[[ "${1:-}" == "--quick" ]] && quick=1

tools/install_deps.sh bench
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DMLSDEFORM_BUILD_TESTS=OFF -DMLSDEFORM_BUILD_TOOLS=OFF \
  -DMLSDEFORM_BUILD_BENCH=ON -DMLSDEFORM_CHOLMOD=ON >/dev/null
cmake --build "$build" -j "$jobs" --target bench_rotation_fit bench_table2 bench_scaling bench_roofline bench_quality

out=$build/bench-results
docs=$root/docs
if ((quick)); then
  docs=$out/quick-docs
fi
mkdir -p "$out" "$docs"
rm -f "$out"/*.json "$out"/error_sweep.csv "$out"/bench_quality.md "$out"/bench_quality_arap.md

common=(--benchmark_out_format=json)
rot_extra=()
t2_extra=(--benchmark_repetitions=3 --benchmark_report_aggregates_only=true)
quality_extra=()
if ((quick)); then
  common+=(--benchmark_min_time=0.01)
  rot_extra=(--cases=10000)
  t2_extra=()
  quality_extra=(--min-time 0)
fi

load() { cut -d' ' -f1-3 /proc/loadavg; }
load_before=$(load)
start=$(date +%s)
echo "== bench_rotation_fit"
"$build/bench/bench_rotation_fit" "${rot_extra[@]}" --error_sweep="$out/error_sweep.csv" \
  --benchmark_out="$out/bench_rotation_fit.json" "${common[@]}"
echo "== bench_table2"
"$build/bench/bench_table2" --benchmark_out="$out/bench_table2.json" "${common[@]}" "${t2_extra[@]}"
echo "== bench_scaling"
"$build/bench/bench_scaling" --benchmark_out="$out/bench_scaling.json" "${common[@]}"
echo "== bench_roofline"
"$build/bench/bench_roofline" --benchmark_out="$out/bench_roofline.json" "${common[@]}"
echo "== bench_quality"
"$build/bench/bench_quality" "${quality_extra[@]}" --json "$out/bench_quality.json" >"$out/bench_quality.md"
echo "== bench_quality --arap"
"$build/bench/bench_quality" --arap "${quality_extra[@]}" --json "$out/bench_quality_arap.json" \
  >"$out/bench_quality_arap.md"
end=$(date +%s)

cmd="tools/bench_report.sh"
((quick)) && cmd+=" --quick"
{
  echo "date=$(date -u '+%Y-%m-%d %H:%M UTC')"
  echo "load_before=$load_before"
  echo "load_after=$(load)"
  echo "suite_seconds=$((end - start))"
  echo "command=$cmd"
  dirty=$(git status --porcelain -- core kernels CMakeLists.txt cmake 2>/dev/null | wc -l)
  echo "commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)$( ((dirty)) && echo " plus uncommitted changes to $dirty library files")"
} >"$out/run.txt"
# Debian's python3-matplotlib lives under /usr/bin/python3; a python3 earlier on PATH (pyenv, venv) may
# lack it.
py=python3
if ! python3 -c 'import matplotlib' 2>/dev/null && /usr/bin/python3 -c 'import matplotlib' 2>/dev/null; then
  py=/usr/bin/python3
fi
"$py" tools/bench_report.py --results "$out" --docs "$docs"
