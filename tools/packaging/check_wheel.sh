#!/usr/bin/env bash
# The Python package as a user gets it (ctest `python_wheel`, so CI runs it in `tools/dev.sh test`):
#   tools/packaging/check_wheel.sh BUILD_DIR [PYTHON]
# 1. the licence in the metadata follows MLSDEFORM_CHOLMOD (MIT without CHOLMOD, GPL-2.0-or-later with it), for
#    a default build and for an existing build directory, through the PEP 517 metadata hook pip itself calls;
# 2. `pip wheel` packages BUILD_DIR as it is configured (MLSDEFORM_BUILD_DIR: only the module and the program are
#    built, so nothing is recompiled after the CI build): exactly one cp3XX wheel, with the module and the program;
# 3. a fresh venv (--system-site-packages, for Debian's numpy and pytest) gets it with `pip install`;
# 4. from a folder outside the source tree: `import mlsdeform` comes from the venv, the `mlsdeform` on the venv's
#    PATH is the C++ program and deforms the bundled human through an animation, and the pytest suite passes
#    against the installed package (MLSDEFORM_PY_REFERENCE: the build's C++ reference, for the bitwise tests).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=$(cd "$1" && pwd)
python=${2:-/usr/bin/python3}
work=$build/python/wheel-check
rm -rf "$work"
mkdir -p "$work/dist" "$work/run" "$work/meta"
fail() { echo "check_wheel: $*" >&2; exit 1; }

# 1. Licence metadata, without building anything. A stand-in build directory has just the cache entries the
# build reads.
license_of() {  # license_of OUTDIR [VAR=VALUE...]: the License field of the metadata the hook writes
  local out=$1; shift
  mkdir -p "$out"
  (cd "$root" && env -u MLSDEFORM_BUILD_DIR -u MLSDEFORM_CHOLMOD "$@" "$python" -c "
import sys
sys.path.insert(0, 'tools/packaging')
import mlsdeform_build
print(mlsdeform_build.prepare_metadata_for_build_wheel(sys.argv[1]))" "$out" >/dev/null)
  sed -n 's/^License: //p' "$out"/*.dist-info/METADATA
}
fake=$work/meta/fake-build
mkdir -p "$fake"
printf '%s\n' MLSDEFORM_BUILD_PYTHON:BOOL=ON MLSDEFORM_BUILD_TOOLS:BOOL=ON MLSDEFORM_CHOLMOD:BOOL=OFF \
  >"$fake/CMakeCache.txt"
[ "$(license_of "$work/meta/default")" = MIT ] || fail "default build: licence not MIT"
[ "$(license_of "$work/meta/on" MLSDEFORM_CHOLMOD=ON)" = GPL-2.0-or-later ] ||
  fail "MLSDEFORM_CHOLMOD=ON: licence not GPL-2.0-or-later"
[ "$(license_of "$work/meta/off" MLSDEFORM_BUILD_DIR="$fake")" = MIT ] ||
  fail "a build directory without CHOLMOD: licence not MIT"
sed -i 's/MLSDEFORM_CHOLMOD:BOOL=OFF/MLSDEFORM_CHOLMOD:BOOL=ON/' "$fake/CMakeCache.txt"
[ "$(license_of "$work/meta/cached-on" MLSDEFORM_BUILD_DIR="$fake")" = GPL-2.0-or-later ] ||
  fail "a build directory with CHOLMOD: licence not GPL-2.0-or-later"
echo "licence metadata: MIT by default, GPL-2.0-or-later with MLSDEFORM_CHOLMOD=ON (both ways of building)"

# 2. The wheel of this build.
(cd "$root" && MLSDEFORM_BUILD_DIR=$build "$python" -m pip wheel -q --no-build-isolation --no-deps \
  -w "$work/dist" .)
wheels=("$work"/dist/*.whl)
[ ${#wheels[@]} -eq 1 ] || fail "expected one wheel, got: ${wheels[*]}"
wheel=${wheels[0]}
tag=$("$python" -c "import sys; print(f'cp{sys.version_info[0]}{sys.version_info[1]}')")
case "$(basename "$wheel")" in
  mlsdeform-*-"$tag-$tag"-linux_*.whl) ;;
  *) fail "unexpected wheel name $(basename "$wheel") (want mlsdeform-<version>-$tag-$tag-linux_<arch>.whl)" ;;
esac
cholmod=$(sed -n 's/^MLSDEFORM_CHOLMOD:BOOL=//p' "$build/CMakeCache.txt")
want=MIT
case "${cholmod^^}" in ON | 1 | TRUE | YES | Y) want=GPL-2.0-or-later ;; esac
"$python" - "$wheel" "$want" <<'EOF'
import sys, zipfile
wheel, want = sys.argv[1:]
names = zipfile.ZipFile(wheel).namelist()
meta = zipfile.ZipFile(wheel).read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
assert f"\nLicense: {want}\n" in meta, f"the wheel's metadata does not say License: {want}"
assert any(n.startswith("mlsdeform/_mlsdeform.") and n.endswith(".so") for n in names), names
assert any(n.endswith(".data/scripts/mlsdeform") for n in names), names
print(f"wheel: {wheel.rsplit('/', 1)[-1]}, License: {want}, {len(names)} files")
EOF

# 3. A fresh venv.
"$python" -m venv --system-site-packages "$work/venv"
"$work/venv/bin/python" -m pip install -q --no-index --no-deps "$wheel"

# 4. From elsewhere.
cd "$work/run"
"$work/venv/bin/python" -c "
import sys, mlsdeform
assert mlsdeform.__file__.startswith(sys.prefix), f'imported {mlsdeform.__file__}, not the venv ({sys.prefix})'
print('import mlsdeform', mlsdeform.__version__, 'from', mlsdeform.__file__)"
program=$(PATH=$work/venv/bin:$PATH command -v mlsdeform)
[ "$program" = "$work/venv/bin/mlsdeform" ] || fail "mlsdeform on PATH is $program, not the venv's"
[ "$(head -c 4 "$program" | od -An -c | tr -d ' ')" = '177ELF' ] || fail "$program is not an ELF program"
"$program" --version
"$program" deform -m "$root/data/human_man.obj" -H "$root/data/human_bend.json" -o "$work/run/human.obj" >/dev/null
[ -s "$work/run/human_0000.obj" ] && [ -s "$work/run/human_0023.obj" ] || fail "the program wrote no animation"
echo "program: $program deformed the human (24 frames)"
# With the venv's bin/ first on PATH, as after `activate`: test_files.py compares with the installed program.
PATH=$work/venv/bin:$PATH MLSDEFORM_PY_REFERENCE=$build/python/mlsdeform_py_reference MLSDEFORM_CLI=$program \
  "$work/venv/bin/python" -m pytest -q -p no:cacheprovider "$root/python/tests"
