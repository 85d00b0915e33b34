#!/usr/bin/env bash
# Builds and tests mlsdeform on Debian 13 (trixie: gcc 14, clang 19, Python 3.13, numpy 2, xsimd 13, Catch2 3)
# from a Debian 12 or 13 host, inside a Debian 13 root that debootstrap makes in build-trixie/root/ (.gitignore:
# /build*/; TRIXIE_ROOT=DIR puts it elsewhere). Needs root (debootstrap, chroot, mounts) and Debian's mirror.
#   tools/trixie.sh setup [PARTS] make the root if missing (debootstrap, a few minutes), then install the project's
#                                 dependencies in it with tools/install_deps.sh PARTS (default: bench), as a user on
#                                 Debian 13 would
#   tools/trixie.sh test [CXX]    setup, then in the root: build build-trixie/<CXX>/ (Release, -Werror, CHOLMOD) with
#                                 CXX=g++ (default) or clang++, and run its ctest: the C++ tests and the Python
#                                 tests (python_tests, python_wheel) against Debian 13's numpy 2 and pybind11 2.13
#   tools/trixie.sh ci            CI's Debian 13 stage (tools/dev.sh test; HACKING.md says what runs where): setup
#                                 with Blender 4.3 instead of CGAL, then build build-trixie/ci/ with clang 19 (Release,
#                                 -Werror, CHOLMOD; no benchmarks or fuzzers) and run the chosen set: the SIMD stages
#                                 and batch fits against the scalar and long-double references, the deformer tests
#                                 (Catch2 3: a random seed each run), the files library and the program, the Python
#                                 tests against numpy 2, and the Blender 4.3 extension installed and run headless
#   tools/trixie.sh shell         a shell in the root, the checkout at /src
# The checkout is bind-mounted at /src, so the build trees land in build-trixie/ beside the root. Mounts live in a
# private mount namespace (unshare): nothing stays mounted when the script ends, however it ends.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
chroot_dir=${TRIXIE_ROOT:-$root/build-trixie/root}
mirror=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
jobs=$(nproc 2>/dev/null || echo 2)
if [ "$(id -u)" -ne 0 ]; then
  echo "trixie.sh: needs root (debootstrap, chroot and bind mounts); run it with sudo" >&2
  exit 2
fi

# Runs a bash command in the root, with /proc, /sys, /dev and the checkout (/src) mounted.
in_root() {
  cp /etc/resolv.conf "$chroot_dir/etc/resolv.conf"
  mkdir -p "$chroot_dir/src"
  unshare --mount --propagation private -- bash -euo pipefail -c '
    r=$1; src=$2; shift 2
    mount -t proc proc "$r/proc"
    mount --rbind /sys "$r/sys"
    mount --rbind /dev "$r/dev"
    mount --bind "$src" "$r/src"
    exec chroot "$r" /usr/bin/env -i HOME=/root TERM="${TERM:-dumb}" LANG=C.UTF-8 \
      PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin "$@"
  ' in_root "$chroot_dir" "$root" "$@"
}

setup() {  # setup [install_deps.sh parts...]
  if [ ! -x "$chroot_dir/usr/bin/apt-get" ]; then
    command -v debootstrap >/dev/null || {
      echo "trixie.sh: installing debootstrap" >&2
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends debootstrap >/dev/null
    }
    echo "trixie.sh: debootstrap trixie into $chroot_dir" >&2
    rm -rf "$chroot_dir"
    mkdir -p "$chroot_dir"
    debootstrap --variant=minbase --include=ca-certificates trixie "$chroot_dir" "$mirror" >"$chroot_dir.log" 2>&1 ||
      {
        tail -n 20 "$chroot_dir.log" >&2
        echo "trixie.sh: debootstrap failed (log: $chroot_dir.log)" >&2
        rm -rf "$chroot_dir"
        exit 1
      }
  fi
  # The project's own script, as on a fresh Debian 13 (it chooses the packages by /etc/os-release).
  in_root bash /src/tools/install_deps.sh "$@"
}

# CI's set (tools/trixie.sh ci): what differs on Debian 13 is the compiler and its warnings, xsimd 13, Catch2 3,
# TBB 2022, Python 3.13 with numpy 2 and pybind11 2.13, and Blender 4.3; these targets and tests reach each.
ci_targets=(mlsdeform _mlsdeform mlsdeform_py_reference mlsdeform_blender_zip
  test_stages test_stages_ring test_batch_accuracy test_batch_fit test_deformer test_deformer_continuity
  test_deformer_session test_deformer_segments test_frames_near_handles test_splats
  test_cli_commands test_cli_mesh_io test_cli_splat_codecs test_cli_scene_hashes)
ci_tests='^(test_[a-z_0-9]+:|python_tests$|blender_)'


case "${1:-}" in
  setup)
    shift
    setup "${@:-bench}"
    ;;
  test)
    cxx=${2:-g++}
    case "$cxx" in
      g++ | clang++) ;;
      *) echo "trixie.sh: test takes g++ or clang++, not '$cxx'" >&2; exit 2 ;;
    esac
    setup bench
    in_root bash -c '
      cd /src
      . /etc/os-release; echo "$PRETTY_NAME: $('"$cxx"' --version | head -n 1)"
      dir=build-trixie/'"$cxx"'
      CXX='"$cxx"' cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DMLSDEFORM_WERROR=ON -DMLSDEFORM_CHOLMOD=ON \
        >/dev/null
      cmake --build "$dir" -j '"$jobs"'
      python3 -c "import numpy, pybind11; print(\"numpy\", numpy.__version__, \"pybind11\", pybind11.__version__)"
      ctest --test-dir "$dir" --output-on-failure -j '"$jobs"'
    '
    ;;
  ci)
    setup blender
    start=$(date +%s)
    in_root bash -c '
      cd /src
      . /etc/os-release; echo "$PRETTY_NAME: $(clang++ --version | head -n 1)"
      dir=build-trixie/ci
      CXX=clang++ cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DMLSDEFORM_WERROR=ON -DMLSDEFORM_CHOLMOD=ON \
        -DMLSDEFORM_BUILD_BENCH=OFF -DMLSDEFORM_BUILD_PYTHON=ON >/dev/null
      cmake --build "$dir" -j '"$jobs"' --target '"${ci_targets[*]}"'
      python3 -c "import numpy, pybind11; print(\"numpy\", numpy.__version__, \"pybind11\", pybind11.__version__)"
      blender --version | head -n 1
      ctest --test-dir "$dir" --output-on-failure -j '"$jobs"' -R "'"$ci_tests"'"
    '
    echo "trixie.sh ci: $(($(date +%s) - start)) s after setup" >&2
    ;;
  shell) setup bench && in_root bash -c 'cd /src && exec bash -i' ;;
  *)
    echo "usage: tools/trixie.sh setup [PARTS] | test [g++|clang++] | ci | shell" >&2
    exit 2
    ;;
esac
