"""Assembles the Blender add-on zip: tools/blender/mlsdeform_blender/ plus the built Python package
(<build>/python/mlsdeform, with its compiled module) as mlsdeform_blender/mlsdeform/.

    python3 tools/blender/make_zip.py <build dir> <out.zip>
"""
import os
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    build, out = argv[1], argv[2]
    pkg = os.path.join(build, "python", "mlsdeform")
    if not any(f.startswith("_mlsdeform") and f.endswith(".so") for f in os.listdir(pkg)):
        print(f"make_zip: no compiled module in {pkg} (build with -DMLSDEFORM_BUILD_PYTHON=ON)", file=sys.stderr)
        return 2
    tmp = out + ".tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        addon = os.path.join(HERE, "mlsdeform_blender")
        for name in sorted(os.listdir(addon)):
            if name.endswith(".py"):
                z.write(os.path.join(addon, name), f"mlsdeform_blender/{name}")
        for name in sorted(os.listdir(pkg)):
            if name.endswith((".py", ".so", ".pyi")):
                z.write(os.path.join(pkg, name), f"mlsdeform_blender/mlsdeform/{name}")
    os.replace(tmp, out)  # all or nothing
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
