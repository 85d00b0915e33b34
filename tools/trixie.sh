#!/usr/bin/env bash
# Builds and tests mlsdeform on Debian 13 (trixie: gcc 14, clang 19, Python 3.13, numpy 2, xsimd 13, Catch2 3)
# from a Debian 12 or 13 host, inside a Debian 13 root that debootstrap makes in build-trixie/root/ (.gitignore:
# /build*/; TRIXIE_ROOT=DIR puts it elsewhere). Needs root (debootstrap, chroot, mounts) and Debian's mirror.
#   tools/trixie.sh setup         make the root if missing (debootstrap, a few minutes), then install the project's
#                                 dependencies in it with tools/install_deps.sh, as a user on Debian 13 would
#   tools/trixie.sh test [CXX]    setup, then in the root: build build-trixie/<CXX>/ (Release, -Werror, CHOLMOD) with
#                                 CXX=g++ (default) or clang++, and run its ctest: the C++ tests and the Python
#                                 tests (python_tests, python_wheel) against Debian 13's numpy 2 and pybind11 2.13
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

setup() {
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
  in_root bash /src/tools/install_deps.sh bench
}

case "${1:-}" in
  setup) setup ;;
  test)
    cxx=${2:-g++}
    case "$cxx" in
      g++ | clang++) ;;
      *) echo "trixie.sh: test takes g++ or clang++, not '$cxx'" >&2; exit 2 ;;
    esac
    setup
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
  shell) setup && in_root bash -c 'cd /src && exec bash -i' ;;
  *)
    echo "usage: tools/trixie.sh setup | test [g++|clang++] | shell" >&2
    exit 2
    ;;
esac
