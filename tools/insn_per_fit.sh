#!/usr/bin/env bash
# Instructions per rotation fit (fit_rotations, axis/angle, one thread) on each SIMD table, counted under qemu's
# user-mode emulation: where NEON cannot be timed (no ARM machine), the instructions each table executes per fit
# are what can be compared. qemu translates one guest instruction per block (-one-insn-per-tb) and logs every block
# it executes (-d exec,nochain); the count for N2 fits minus the count for N1, over N2 - N1, is the instructions per
# fit, set-up and start-up cancelled. Deterministic: the same binary gives the same count on every run.
#
#   tools/insn_per_fit.sh [X86_BUILD] [ARM64_BUILD]     (defaults: build, build-arm64; each needs fit_count built:
#                                                        cmake --build <dir> --target fit_count)
#
# x86-64 runs under qemu-x86_64 -cpu max (SSE4.2, AVX2 and FMA; qemu has no AVX-512), aarch64 under qemu-aarch64;
# both qemu 10 (tools/install_deps.sh arm64 puts them in /opt/qemu-trixie/bin on Debian 12). Prints a markdown table.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
x86_build=${1:-$root/build}
arm_build=${2:-$root/build-arm64}
qemu_dir=${QEMU_DIR:-/opt/qemu-trixie/bin}
qx86=$qemu_dir/qemu-x86_64
qarm=$qemu_dir/qemu-aarch64
[ -x "$qx86" ] || qx86=$(command -v qemu-x86_64)
[ -x "$qarm" ] || qarm=$(command -v qemu-aarch64)
n1=${N1:-2048}
n2=${N2:-10240}

# count QEMU [QEMU_OPTIONS...] -- PROGRAM ARGS...: guest instructions executed.
count() {
  local q=()
  while [ "$1" != -- ]; do q+=("$1"); shift; done
  shift
  "${q[@]}" -one-insn-per-tb -d exec,nochain "$@" 2>&1 >/dev/null | grep -c '^Trace'
}

# row LABEL ISA TYPE QEMU [QEMU_OPTIONS...] -- PROGRAM
row() {
  local label=$1 isa=$2 type=$3
  shift 3
  local a b
  a=$(MLSDEFORM_ISA=$isa count "$@" "$type" "$n1")
  b=$(MLSDEFORM_ISA=$isa count "$@" "$type" "$n2")
  printf '| %s | %s | %s | %d |\n' "$label" "$isa" "$type" $(((b - a) / (n2 - n1)))
}

echo "| architecture | ISA | type | instructions per fit |"
echo "|---|---|---|---:|"
for type in float double; do
  for isa in scalar sse4_2 avx2; do
    row x86-64 "$isa" "$type" "$qx86" -cpu max -- "$x86_build/tools/fit_count"
  done
  for isa in scalar neon; do
    row aarch64 "$isa" "$type" "$qarm" -L / -- "$arm_build/tools/fit_count"
  done
done
