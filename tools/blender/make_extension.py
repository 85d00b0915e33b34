"""Assembles the Blender 4.2+ extension of the add-on: blender_manifest.toml (from blender_manifest.toml.in), the
add-on's Python files and the module-only wheel of the Python package under wheels/, at the archive's root, the
layout `blender --command extension build` writes.

    python3 tools/blender/make_extension.py <wheel> <out.zip>

The wheel comes from `MLSDEFORM_WHEEL_PROGRAM=OFF pip wheel ...` (tools/blender/test_extension.sh): its version,
licence and platform tag fill in the manifest, so that the extension says what its compiled module is.
"""
import os
import re
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
# Wheel platform tag -> Blender platform name (Blender's extension tooling maps the same way).
PLATFORMS = {"linux_x86_64": "linux-x64", "linux_aarch64": "linux-arm64"}
SPDX = {"MIT": "SPDX:MIT", "GPL-2.0-or-later": "SPDX:GPL-2.0-or-later"}


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    wheel, out = argv[1], argv[2]
    name = os.path.basename(wheel)
    parts = name[: -len(".whl")].split("-")
    if not name.endswith(".whl") or len(parts) != 5 or parts[0] != "mlsdeform":
        print(
            f"make_extension: {wheel}: not a wheel of mlsdeform (mlsdeform-<version>-<py>-<abi>-<platform>.whl)",
            file=sys.stderr,
        )
        return 2
    version, platform = parts[1], parts[4]
    if platform not in PLATFORMS:
        print(
            f"make_extension: {wheel}: platform {platform} has no Blender name here ({', '.join(PLATFORMS)})",
            file=sys.stderr,
        )
        return 2
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        if any(".data/" in n for n in names):
            print(
                f"make_extension: {wheel} carries the program (build it with MLSDEFORM_WHEEL_PROGRAM=OFF): "
                "Blender would unpack it into its site-packages",
                file=sys.stderr,
            )
            return 2
        meta = z.read(f"mlsdeform-{version}.dist-info/METADATA").decode()
    m = re.search(r"^License: (.*)$", meta, re.M)
    if not m or m.group(1) not in SPDX:
        print(f"make_extension: {wheel}: licence {m.group(1) if m else '(none)'} unknown", file=sys.stderr)
        return 2
    with open(os.path.join(HERE, "blender_manifest.toml.in")) as f:
        manifest = f.read()
    for key, value in (
        ("VERSION", version),
        ("LICENSE", SPDX[m.group(1)]),
        ("PLATFORM", PLATFORMS[platform]),
        ("WHEEL", name),
    ):
        manifest = manifest.replace(f"@{key}@", value)
    tmp = out + ".tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("blender_manifest.toml", manifest)
        addon = os.path.join(HERE, "mlsdeform_blender")
        for f in sorted(os.listdir(addon)):
            if f.endswith(".py"):
                z.write(os.path.join(addon, f), f)
        z.write(wheel, f"wheels/{name}", compress_type=zipfile.ZIP_STORED)  # already compressed
    os.replace(tmp, out)  # all or nothing
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
