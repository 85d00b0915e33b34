#!/usr/bin/env bash
# The Blender 4.2+ extension (ctest `blender_extension`; `tools/dev.sh blender` builds it too):
#   tools/blender/test_extension.sh BUILD_DIR PYTHON [BLENDER]
# 1. the module-only wheel of BUILD_DIR (MLSDEFORM_WHEEL_PROGRAM=OFF: nothing recompiled) and the extension
#    BUILD_DIR/mlsdeform_blender_extension.zip (tools/blender/make_extension.py);
# 2. its manifest and layout against Blender's rules (check_extension.py), and the checker against a broken copy;
# 3. with BLENDER 4.2 or newer (Debian 13's 4.3: tools/trixie.sh ci): Blender's own validator and installer
#    (`--command extension validate`, `install-file`), then the add-on's headless test (tests/blender/test_addon.py)
#    on the installed extension, bl_ext.user_default.mlsdeform_blender, with the compiled package Blender unpacked
#    from the wheel; with an older BLENDER (Debian 12's 3.4, no extension support): the extension as Blender 4.2+
#    installs it, its wheel unpacked as it is into a site-packages folder and the add-on without a compiled package
#    of its own enabled, through the same test.
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

# Blender's version as major * 100 + minor (3.4 -> 304, 4.3 -> 403); 0 without one.
blender_version=0
if [ -n "$blender" ]; then
  blender_version=$("$blender" -b --factory-startup --version 2>/dev/null |
    sed -n 's/^Blender \([0-9]*\)\.\([0-9]*\).*/\1 \2/p' | head -n 1 | { read -r a b && echo $((a * 100 + b)); })
  [ -n "$blender_version" ] || fail "cannot read the version of $blender"
fi
# User folders in the build tree: the user's own Blender set-up is never read or touched.
export BLENDER_USER_SCRIPTS=$work/user/scripts BLENDER_USER_CONFIG=$work/user/config
export BLENDER_USER_EXTENSIONS=$work/user/extensions
if [ "$blender_version" -ge 402 ]; then
  "$blender" -b --factory-startup --command extension validate "$extension"
  "$blender" -b --factory-startup --command extension install-file -r user_default --enable "$extension"
  "$blender" -b --factory-startup --python-exit-code 1 --python "$root/tests/blender/test_addon.py" -- \
    --installed-extension "$BLENDER_USER_EXTENSIONS"
elif [ -n "$blender" ]; then
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
  "$blender" -b --factory-startup --python-exit-code 1 --python "$root/tests/blender/test_addon.py" -- \
    "$work/addon.zip" "$work/site-packages"
fi
