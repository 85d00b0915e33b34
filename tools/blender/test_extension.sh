#!/usr/bin/env bash
# The Blender 4.2+ extension (ctest `blender_extension`; `tools/dev.sh blender` builds it too):
#   tools/blender/test_extension.sh BUILD_DIR PYTHON [BLENDER]
# 1. the module-only wheel of BUILD_DIR (MLSDEFORM_WHEEL_PROGRAM=OFF: nothing recompiled) and the extension
#    BUILD_DIR/mlsdeform_blender_extension.zip (tools/blender/make_extension.py);
# 2. its manifest and layout against Blender's rules (check_extension.py), and the checker against a broken copy;
# 3. with BLENDER (Debian's 3.4, which has no extension support): the extension as Blender 4.2+ installs it,
#    its wheel unpacked as it is into a site-packages folder and the add-on without a compiled package of its own
#    enabled, through the add-on's headless test (tests/blender/test_addon.py).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=$(cd "$1" && pwd)
python=$2
blender=${3:-}
work=$build/blender_extension
rm -rf "$work"
mkdir -p "$work/wheel" "$work/site-packages" "$work/broken"
fail() { echo "test_extension: $*" >&2; exit 1; }

(cd "$root" && MLSDEFORM_BUILD_DIR=$build MLSDEFORM_WHEEL_PROGRAM=OFF "$python" -m pip wheel -q --no-build-isolation \
  --no-deps -w "$work/wheel" .)
wheel=$(echo "$work"/wheel/*.whl)
extension=$build/mlsdeform_blender_extension.zip
"$python" "$root/tools/blender/make_extension.py" "$wheel" "$extension"
"$python" "$root/tools/blender/check_extension.py" "$extension"

# The checker fails where Blender would: a bad id, a tagline ending in punctuation, a wheel not in the archive.
"$python" - "$extension" "$work/broken/extension.zip" <<'EOF'
import sys, zipfile
src, dst = sys.argv[1:]
with zipfile.ZipFile(src) as z, zipfile.ZipFile(dst, "w") as out:
    for n in z.namelist():
        data = z.read(n)
        if n == "blender_manifest.toml":
            text = data.decode().replace('id = "mlsdeform_blender"', 'id = "_mlsdeform"')
            text = text.replace('Empty handles"', 'Empty handles."').replace("./wheels/", "./wheel/")
            data = text.encode()
        out.writestr(n, data)
EOF
if out=$("$python" "$root/tools/blender/check_extension.py" "$work/broken/extension.zip"); then
  fail "the checker passed a broken manifest"
fi
for want in '"id"' '"tagline": must not end with punctuation' 'is not in the archive'; do
  grep -qF "$want" <<<"$out" || fail "the checker did not report $want: $out"
done
echo "check_extension.py refuses a broken manifest (id, tagline, wheel path)"

if [ -n "$blender" ]; then
  # Blender 4.2+ unpacks the wheel as it is (zip extraction) into <extensions>/.local/lib/python3.X/site-packages.
  "$python" - "$wheel" "$extension" "$work/site-packages" "$work/addon.zip" <<'EOF'
import sys, zipfile
wheel, extension, site, addon = sys.argv[1:]
zipfile.ZipFile(wheel).extractall(site)
with zipfile.ZipFile(extension) as z, zipfile.ZipFile(addon, "w") as out:
    for n in z.namelist():
        if n.endswith(".py"):
            out.writestr("mlsdeform_blender/" + n, z.read(n))
EOF
  BLENDER_USER_SCRIPTS=$work/user/scripts BLENDER_USER_CONFIG=$work/user/config \
    "$blender" -b --factory-startup --python-exit-code 1 --python "$root/tests/blender/test_addon.py" -- \
    "$work/addon.zip" "$work/site-packages"
fi
