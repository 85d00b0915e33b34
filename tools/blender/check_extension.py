"""Checks a Blender extension archive against the rules Blender's own extension tooling applies, as far as they can
be checked without Blender 4.2+ (Debian 12 has Blender 3.4, which knows no extensions):

    python3 tools/blender/check_extension.py build/mlsdeform_blender_extension.zip

The rules are those of `blender --command extension validate` and `... build` (strict mode), as written in
Blender's scripts/addons_core/bl_pkg/cli/blender_ext.py (blender/blender at 774bb44d, 2025): the manifest's
required keys and their types, `id` a Python identifier without leading, trailing or double "_", `version` and
`schema_version` semantic versions, `blender_version_min`/`_max` three numbers, a `tagline` of at most 64
characters that does not end in punctuation, `copyright` entries "YEAR[-YEAR] name", `permissions` a table of
the five known keys, `tags` from Blender's list for add-ons (_bpy_internal/extensions/tags.py), `wheels` paths
with forward slashes naming files that follow the wheel file-name spec, and for an add-on an `__init__.py`.
Checked beyond them: no unknown key (Blender ignores them; here a typo is an error), `license` entries as SPDX
identifiers (extensions.blender.org requires them), each wheel present in the archive and built for a declared
platform (its platform tag mapped as Blender maps it, linux_x86_64 -> linux-x64), and no `.data` directory in a
wheel (Blender unpacks a wheel as it is into its site-packages). Exit code 0 and "ok", or 1 and one line per
problem.
"""
import os
import re
import sys
import tomllib
import zipfile

SEMVER = re.compile(
    r"^(0|[1-9]\d*)\.(0|[1-9]\d*)\.(0|[1-9]\d*)"
    r"(?:-((?:0|[1-9]\d*|\d*[a-zA-Z-][0-9a-zA-Z-]*)(?:\.(?:0|[1-9]\d*|\d*[a-zA-Z-][0-9a-zA-Z-]*))*))?"
    r"(?:\+([0-9a-zA-Z-]+(?:\.[0-9a-zA-Z-]+)*))?$"
)
CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")
REQUIRED = {
    "schema_version": str,
    "id": str,
    "name": str,
    "tagline": str,
    "version": str,
    "type": str,
    "maintainer": str,
    "license": list,
    "blender_version_min": str,
}
OPTIONAL = {
    "blender_version_max": str,
    "website": str,
    "copyright": list,
    "permissions": dict,
    "tags": list,
    "platforms": list,
    "wheels": list,
    "build": dict,
}
PERMISSIONS = {"files", "network", "clipboard", "camera", "microphone"}
PLATFORMS = {"windows-x64", "windows-arm64", "macos-x64", "macos-arm64", "linux-x64", "linux-arm64"}
ADDON_TAGS = {
    "3D View",
    "Add Curve",
    "Add Mesh",
    "Animation",
    "Bake",
    "Camera",
    "Compositing",
    "Development",
    "Game Engine",
    "Geometry Nodes",
    "Grease Pencil",
    "Import-Export",
    "Lighting",
    "Material",
    "Modeling",
    "Mesh",
    "Node",
    "Object",
    "Paint",
    "Pipeline",
    "Physics",
    "Render",
    "Rigging",
    "Scene",
    "Sculpt",
    "Sequencer",
    "System",
    "Text Editor",
    "Tracking",
    "User Interface",
    "UV",
}
WHEEL_PLATFORMS = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}


def plain_text(value):
    if not value.strip():
        return "a non-empty string expected"
    if value != value.strip():
        return "text without leading/trailing white space expected"
    if CONTROL.search(value):
        return "text without control characters expected"
    return None


def terse(value):
    if len(value) > 64:
        return f"at most 64 characters expected, found {len(value)}"
    if (error := plain_text(value)) is not None:
        return error
    if not (value[-1].isalnum() or value[-1] in ")]}"):
        return "must not end with punctuation"
    return None


def blender_version(value):
    parts = value.split(".")
    if len(parts) != 3 or not all(p.isdigit() for p in parts):
        return f'three numbers separated by "." expected, found {value!r}'
    return None


def wheel_blender_platform(platform_tag):
    system, _, machine = platform_tag.partition("_")
    system = {"macosx": "macos", "win": "windows"}.get(system, system)
    if system.startswith(("manylinux", "musllinux")):
        system = "linux"
    arch = next(
        (blender for wheel, blender in WHEEL_PLATFORMS.items() if machine == wheel or machine.endswith("_" + wheel)),
        machine.rpartition("_")[2],
    )
    return f"{system}-{arch}"


def check_manifest(m, names, prefix):
    problems = []
    for key, kind in {**REQUIRED, **OPTIONAL}.items():
        if key not in m:
            if key in REQUIRED:
                problems.append(f'missing "{key}"')
            continue
        if not isinstance(m[key], kind):
            problems.append(f'"{key}" must be a {kind.__name__}, not a {type(m[key]).__name__}')
    for key in m:
        if key not in REQUIRED and key not in OPTIONAL:
            problems.append(f'unknown key "{key}"')
    if problems:
        return problems

    def bad(key, error):
        if error is not None:
            problems.append(f'"{key}": {error}')

    ident = m["id"]
    bad(
        "id",
        None
        if ident.isidentifier() and "__" not in ident and not ident.startswith("_") and not ident.endswith("_")
        else f'{ident!r} is no identifier without leading, trailing or double "_"',
    )
    for key in ("schema_version", "version"):
        bad(key, None if SEMVER.match(m[key]) else f"a semantic version expected, found {m[key]!r}")
    for key in ("name", "maintainer"):
        bad(key, plain_text(m[key]))
    if "website" in m:
        bad("website", plain_text(m["website"]))
    bad("tagline", terse(m["tagline"]))
    bad("type", None if m["type"] in ("add-on", "theme") else f"\"add-on\" or \"theme\" expected, found {m['type']!r}")
    bad("blender_version_min", blender_version(m["blender_version_min"]))
    if m.get("blender_version_max"):
        bad("blender_version_max", blender_version(m["blender_version_max"]))
    if not m["license"]:
        bad("license", "may not be empty")
    for entry in m["license"]:
        bad(
            "license",
            None
            if isinstance(entry, str) and re.fullmatch(r"SPDX:[A-Za-z0-9.+-]+", entry)
            else f'{entry!r} is no "SPDX:<identifier>"',
        )
    for entry in m.get("copyright", []):
        year, _, who = entry.partition(" ") if isinstance(entry, str) else ("", "", "")
        bad(
            "copyright",
            None if re.fullmatch(r"\d+(-\d+)?", year) and who.strip() else f'{entry!r} is not "YEAR[-YEAR] name"',
        )
    for key, text in m.get("permissions", {}).items():
        bad("permissions", None if key in PERMISSIONS else f"unknown permission {key!r}")
        bad(f"permissions.{key}", terse(text) if isinstance(text, str) else "a string expected")
    for key, known in (("tags", ADDON_TAGS if m["type"] == "add-on" else None), ("platforms", PLATFORMS)):
        if key in m:
            if not m[key]:
                bad(key, "may not be empty")
            for entry in m[key]:
                if not isinstance(entry, str) or not entry.strip():
                    bad(key, f"{entry!r} is no non-empty string")
                elif known is not None and entry not in known:
                    bad(key, f"{entry!r} is not one of Blender's")
    if "generated" in m.get("build", {}):
        bad("build", "[build.generated] is reserved for Blender's build")
    for wheel in m.get("wheels", []):
        if not isinstance(wheel, str) or '"' in wheel or "\\" in wheel or plain_text(wheel) is not None:
            bad("wheels", f"{wheel!r}: a path with forward slashes expected")
            continue
        base = os.path.basename(wheel)
        fields = base[: -len(".whl")].split("-")
        if not base.endswith(".whl") or not 5 <= len(fields) <= 6:
            bad("wheels", f"{wheel!r} does not follow the wheel file-name spec")
            continue
        inside = prefix + os.path.normpath(wheel).replace(os.sep, "/")
        if inside not in names:
            bad("wheels", f"{wheel!r} is not in the archive")
        platform = wheel_blender_platform(fields[-1])
        if fields[-1] != "any" and platform not in m.get("platforms", [platform]):
            bad("wheels", f"{wheel!r} is built for {platform}, not a declared platform")
    if m["type"] == "add-on" and prefix + "__init__.py" not in names:
        problems.append("an add-on needs __init__.py beside the manifest")
    return problems


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    with zipfile.ZipFile(argv[1]) as z:
        names = set(z.namelist())
        if "blender_manifest.toml" in names:
            prefix = ""
        else:
            found = [n for n in names if n.count("/") == 1 and n.endswith("/blender_manifest.toml")]
            if len(found) != 1:
                print(f"{argv[1]}: no blender_manifest.toml at the root or in one folder")
                return 1
            prefix = found[0][: -len("blender_manifest.toml")]
        try:
            manifest = tomllib.loads(z.read(prefix + "blender_manifest.toml").decode())
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
            print(f"{argv[1]}: blender_manifest.toml: {e}")
            return 1
        problems = check_manifest(manifest, names, prefix)
        for wheel in manifest.get("wheels", []) if not problems else []:
            inside = prefix + os.path.normpath(wheel).replace(os.sep, "/")
            with z.open(inside) as f, zipfile.ZipFile(f) as w:
                if any(".data/" in n for n in w.namelist()):
                    problems.append(f'"wheels": {wheel!r} has a .data folder, which Blender would unpack as it is')
    for p in problems:
        print(f"{argv[1]}: blender_manifest.toml: {p}")
    if not problems:
        print(f"{argv[1]}: ok")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
