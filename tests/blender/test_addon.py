"""Headless test of the Blender add-on:

    BLENDER_USER_SCRIPTS=$tmp/scripts BLENDER_USER_CONFIG=$tmp/config \
        blender -b --factory-startup --python tests/blender/test_addon.py -- build/mlsdeform_blender.zip

Installs the zip into the temporary user folder, builds a scene (a cylinder with n-gon caps and a loose
vertex, three Empties, one pair of them a segment handle), binds, moves Empties, updates, and compares the
evaluated vertices with the add-on's own Python module (mlsdeform.Deformer) on the same data, bitwise in float.
Then: object transforms, frame changes of keyframed Empties, bake, a deleted Empty, undo, save and reopen,
unbind (restores the rest mesh exactly). Prints "N passed, M failed" and exits non-zero on a failure.

    ... --python tests/blender/test_addon.py -- addon.zip SITE_PACKAGES

is the Blender 4.2+ extension as this Blender can run it (tools/blender/test_extension.sh): an add-on without
the compiled package inside, which imports the one unpacked from the extension's wheel into SITE_PACKAGES, as
Blender 4.2+ unpacks it into its extensions' site-packages.

    ... --python tests/blender/test_addon.py -- --installed-extension EXTENSIONS

is the extension installed by Blender 4.2+ itself (`blender --command extension install-file -r user_default`,
with BLENDER_USER_EXTENSIONS=EXTENSIONS), enabled as bl_ext.user_default.mlsdeform_blender.
"""
import importlib
import math
import os
import sys
import tempfile
import time
import traceback

import bpy
import numpy as np

ARGS = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
# `-- --installed-extension EXTENSIONS`: the extension that Blender 4.2+'s own installer put into the user
# repository of EXTENSIONS (BLENDER_USER_EXTENSIONS), its wheel unpacked by Blender into EXTENSIONS/.local.
INSTALLED = ARGS[1] if ARGS[:1] == ["--installed-extension"] and len(ARGS) == 2 else None
ZIP = ARGS[0] if ARGS and not INSTALLED else None
if len(ARGS) > 1 and not INSTALLED:
    sys.path.insert(0, ARGS[1])
results = {"passed": 0, "failed": 0}


def check(name, ok, detail=""):
    if ok:
        results["passed"] += 1
        print(f"ok   {name}")
    else:
        results["failed"] += 1
        print(f"FAIL {name} {detail}")


def cylinder(rings=20, segments=24, radius=0.3, height=2.0):
    verts, faces = [], []
    for r in range(rings + 1):
        z = height * r / rings
        for s in range(segments):
            a = 2 * math.pi * s / segments
            verts.append((radius * math.cos(a), radius * math.sin(a), z))
    for r in range(rings):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            faces.append((a, b, b + segments, a + segments))
    faces.append(tuple(range(segments - 1, -1, -1)))  # n-gon caps
    faces.append(tuple(range(rings * segments, (rings + 1) * segments)))
    verts.append((2.0, 2.0, 2.0))  # a loose vertex
    mesh = bpy.data.meshes.new("cyl")
    mesh.from_pydata(verts, [], faces)
    obj = bpy.data.objects.new("cyl", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def empty(name, location):
    e = bpy.data.objects.new(name, None)
    e.location = location
    bpy.context.scene.collection.objects.link(e)
    return e


def evaluated(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    me = obj.evaluated_get(dg).data
    co = np.empty(len(me.vertices) * 3, dtype=np.float32)
    me.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def key_coords(obj):
    """The add-on's output: the "MLS Deform" shape key's coordinates."""
    key = obj.data.shape_keys.key_blocks["MLS Deform"]
    co = np.empty(len(key.data) * 3, dtype=np.float32)
    key.data.foreach_get("co", co)
    return co.reshape(-1, 3)


def matches(obj, want):
    """Vertices mode: the evaluated mesh equals `want` bitwise. Shape-key mode: the key equals `want` bitwise,
    and the evaluated mesh equals it to the rounding of Blender's relative shape-key blend,
    basis + 1.0 * (key - basis): two float32 roundings, each at most half an ulp of max(|basis|, |key|)
    <= eps32 (|basis| + |key|) per coordinate."""
    if obj["mlsdeform_mode"] == "vertices":
        return np.array_equal(evaluated(obj), want)
    key, ev, basis = key_coords(obj), evaluated(obj), rest_coords(obj)
    bound = np.finfo(np.float32).eps * (np.abs(basis) + np.abs(key))
    return np.array_equal(key, want) and bool(np.all(np.abs(ev - key) <= bound))


def rest_coords(obj):
    """The rest positions: the add-on's copy while bound in vertices mode, else the mesh's Basis or vertices."""
    mesh = obj.data
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    if "mlsdeform_rest" in mesh.attributes and obj.get("mlsdeform_mode") == "vertices":
        mesh.attributes["mlsdeform_rest"].data.foreach_get("vector", co)
    elif mesh.shape_keys is not None:
        mesh.shape_keys.reference_key.data.foreach_get("co", co)
    else:
        mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def select(objs, active):
    for o in bpy.context.scene.objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    bpy.context.view_layer.objects.active = active


def local(obj, empties):
    """The Empties' positions in obj's local space, as the add-on computes them (mathutils, then float64)."""
    inv = obj.matrix_world.inverted()
    return np.array([np.array(inv @ e.matrix_world.translation, dtype=np.float64) for e in empties])


def expected(addon, obj, rest, now, seg):
    """The add-on's Python module on the same data: points = Empties not in the segment, float32."""
    V = rest_coords(obj)
    pts = [i for i in range(len(rest)) if i not in seg]
    d = addon.mlsdeform.Deformer(V, points=rest[pts], segments=(rest[[seg[0]]], rest[[seg[1]]]))
    return d.deform(points=now[pts], segments=(now[[seg[0]]], now[[seg[1]]]))


def main():
    if INSTALLED:
        name = "bl_ext.user_default.mlsdeform_blender"
        bpy.ops.preferences.addon_enable(module=name)
        addon = importlib.import_module(name)
        check("extension enabled from the user repository", name in bpy.context.preferences.addons, name)
        check(
            "the compiled package is the one Blender unpacked from the extension's wheel",
            os.path.realpath(addon.mlsdeform.__file__).startswith(os.path.realpath(INSTALLED) + os.sep),
            addon.mlsdeform.__file__,
        )
    else:
        bpy.ops.preferences.addon_install(filepath=ZIP, overwrite=True)
        bpy.ops.preferences.addon_enable(module="mlsdeform_blender")
        import mlsdeform_blender as addon

    check("add-on enabled, module imported", hasattr(bpy.ops.mlsdeform, "bind"))
    if len(ARGS) > 1 and not INSTALLED:
        check(
            "the compiled package is the wheel's, unpacked into the site-packages",
            os.path.realpath(addon.mlsdeform.__file__).startswith(os.path.realpath(ARGS[1]) + os.sep),
            addon.mlsdeform.__file__,
        )
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    obj = cylinder()
    rest_mesh = rest_coords(obj).copy()
    e0 = empty("h0_base", (0.0, 0.0, 0.0))
    e1 = empty("h1_top", (0.0, 0.0, 2.0))
    e2 = empty("h2_side", (0.3, 0.0, 1.0))
    e3 = empty("h3_side_end", (0.3, 0.0, 1.4))
    e2["mlsdeform_segment_to"] = "h3_side_end"
    empties = [e0, e1, e2, e3]
    select(empties + [obj], obj)
    check("bind", bpy.ops.mlsdeform.bind() == {"FINISHED"})
    rest = local(obj, empties)
    bpy.context.view_layer.update()
    check(
        "rest pose: evaluated mesh equals the rest mesh to rounding",
        np.abs(evaluated(obj) - rest_mesh).max() <= 1e-5,
        f"{np.abs(evaluated(obj) - rest_mesh).max()}",
    )

    e1.location = (0.6, 0.2, 1.8)
    e3.location = (0.5, 0.1, 1.5)
    bpy.context.view_layer.update()
    now = local(obj, empties)
    got, want = evaluated(obj), expected(addon, obj, rest, now, (2, 3))
    check(
        "moved Empties: the evaluated vertices equal mlsdeform.Deformer's bitwise (float)",
        matches(obj, want),
        f"max diff {np.abs(got - want).max()}",
    )
    obj.mlsdeform.precision = "double"
    bpy.context.view_layer.update()
    V = rest_coords(obj).astype(np.float64)
    d = addon.mlsdeform.Deformer(V, points=rest[[0, 1]], segments=(rest[[2]], rest[[3]]))
    want64 = d.deform(points=now[[0, 1]], segments=(now[[2]], now[[3]])).astype(np.float32)
    check("precision double: the double session's result rounded once to float", matches(obj, want64))
    obj.mlsdeform.precision = "float"
    bpy.context.view_layer.update()
    # ARAP: the session gets the mesh's triangles and the ARAP options (warm start off: a pure function of the
    # handles, so that the module on the same data gives the same bits).
    obj.mlsdeform.arap_warm_start = False
    obj.mlsdeform.arap_iterations = 3
    bpy.context.view_layer.update()
    obj.data.calc_loop_triangles()
    F = np.array([list(t.vertices) for t in obj.data.loop_triangles])
    d = addon.mlsdeform.Deformer(
        rest_coords(obj),
        points=rest[[0, 1]],
        segments=(rest[[2]], rest[[3]]),
        faces=F,
        arap_iterations=3,
        arap_acceleration="anderson",
    )
    want_arap = d.deform(points=now[[0, 1]], segments=(now[[2]], now[[3]]))
    check(
        "ARAP iterations: the module's MLS + 3 Anderson-accelerated ARAP iterations bitwise",
        matches(obj, want_arap),
        f"max diff {np.abs(evaluated(obj) - want_arap).max()}",
    )
    check("ARAP iterations: they change the result", not matches(obj, got))
    obj.mlsdeform.arap_iterations = 0
    obj.mlsdeform.arap_warm_start = True
    bpy.context.view_layer.update()
    check(
        "bound without shape keys: vertices mode, the rest positions kept exactly",
        obj["mlsdeform_mode"] == "vertices" and np.array_equal(rest_coords(obj), rest_mesh),
    )

    # Object transforms: move the mesh object and its Empties together: handles are in its local space.
    t = (1.0, -2.0, 0.5)
    for o in [obj] + empties:
        o.location = tuple(a + b for a, b in zip(o.location, t))
    bpy.context.view_layer.update()
    # The local positions change only by the rounding of the float32 transforms (a bitwise comparison with
    # the module on them); with world positions instead, the mesh would move by the translation.
    check(
        "moving the mesh with its Empties: handles in its local space",
        matches(obj, expected(addon, obj, rest, local(obj, empties), (2, 3))),
    )
    check("... and the shape stays where it was to rounding", np.abs(evaluated(obj) - got).max() <= 1e-2)
    for o in [obj] + empties:
        o.location = tuple(a - b for a, b in zip(o.location, t))
    bpy.context.view_layer.update()

    # Animation: keyframed Empty, frame changes.
    scene = bpy.context.scene
    e1.location = (0.0, 0.0, 2.0)
    e1.keyframe_insert("location", frame=1)
    e1.location = (0.8, 0.0, 1.6)
    e1.keyframe_insert("location", frame=10)
    scene.frame_set(10)
    bpy.context.view_layer.update()
    now = local(obj, empties)
    check("frame change of a keyframed Empty deforms", matches(obj, expected(addon, obj, rest, now, (2, 3))))
    start = time.perf_counter()
    for f in range(1, 11):
        scene.frame_set(f)
    per_frame = 1000 * (time.perf_counter() - start) / 10
    print(f"info: {len(obj.data.vertices)} vertices, frame_set with the deformation: {per_frame:.2f} ms per frame")

    # Bake a frame range as shape keys.
    select([obj], obj)
    check("bake frames 1-3", bpy.ops.mlsdeform.bake(frame_start=1, frame_end=3) == {"FINISHED"})
    keys = obj.data.shape_keys.key_blocks
    check("bake wrote three shape keys", all(f"MLS f{f:04d}" in keys for f in (1, 2, 3)))
    check(
        "after bake: shape-key mode with the rest pose as Basis",
        obj["mlsdeform_mode"] == "shape_key" and np.array_equal(rest_coords(obj), rest_mesh),
    )
    scene.frame_set(10)
    bpy.context.view_layer.update()
    check("shape-key mode deforms live", matches(obj, expected(addon, obj, rest, local(obj, empties), (2, 3))))

    # A deleted Empty: no exception; the error is stored for the panel, the mesh keeps its last pose.
    last = evaluated(obj).copy()
    bpy.data.objects.remove(e0)
    bpy.context.view_layer.update()
    check("deleted Empty is reported on the object", "no longer exists" in obj.get("mlsdeform_error", ""))
    check("deleted Empty: the mesh keeps its last pose", np.array_equal(evaluated(obj), last))

    # Save and reopen: the binding survives (custom properties), the session is rebuilt.
    e0 = empty("h0_base", (0.0, 0.0, 0.0))
    path = os.path.join(tempfile.mkdtemp(), "bound.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["cyl"]
    bpy.data.objects["h1_top"].animation_data_clear()
    bpy.data.objects["h1_top"].location = (0.3, 0.3, 1.9)
    bpy.context.view_layer.update()
    empties = [bpy.data.objects[n] for n in ("h0_base", "h1_top", "h2_side", "h3_side_end")]
    now = local(obj, empties)
    check("after save and reopen the binding works", matches(obj, expected(addon, obj, rest, now, (2, 3))))

    # Unbind restores the rest mesh exactly (and removes what bind added).
    select([obj], obj)
    check("unbind", bpy.ops.mlsdeform.unbind() == {"FINISHED"})
    bpy.context.view_layer.update()
    check("unbind restores the rest mesh exactly", np.array_equal(evaluated(obj), rest_mesh))
    check(
        "unbind leaves no MLS shape key",
        obj.data.shape_keys is None or "MLS Deform" not in obj.data.shape_keys.key_blocks,
    )
    # A fresh binding in vertices mode: unbind puts back the exact rest positions from the attribute.
    select([bpy.data.objects[n] for n in ("h0_base", "h1_top")] + [obj], obj)
    obj2 = cylinder()
    rest2 = rest_coords(obj2).copy()
    select([bpy.data.objects["h0_base"], bpy.data.objects["h1_top"], obj2], obj2)
    bpy.ops.mlsdeform.bind()
    bpy.data.objects["h1_top"].location = (0.5, 0.5, 1.5)
    bpy.context.view_layer.update()
    check("vertices mode: the mesh is deformed", not np.array_equal(evaluated(obj2), rest2))
    select([obj2], obj2)
    bpy.ops.mlsdeform.unbind()
    bpy.context.view_layer.update()
    check(
        "vertices mode: unbind restores the rest mesh exactly, no attribute left",
        np.array_equal(evaluated(obj2), rest2) and "mlsdeform_rest" not in obj2.data.attributes,
    )

    # Errors go to the operator's report, not a traceback.
    # (Headless, Blender turns an operator's error report into a RuntimeError; in the UI it is the status bar.)
    select([obj], obj)
    try:
        bpy.ops.mlsdeform.bind()
        check("bind without Empties reports an error", False, "no error")
    except RuntimeError as e:
        check("bind without Empties reports an error", "Select one or more Empties" in str(e), str(e))


def performance():
    """Per-update time for a 10^5-vertex mesh with 8 point handles (printed, not asserted: timings are for
    benchmarks): the library's deform (the add-on's own measure) and the whole update through Blender."""
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    obj = cylinder(rings=400, segments=250, radius=0.5, height=4.0)
    empties = [empty(f"p{i}", (0.5 * math.cos(i), 0.5 * math.sin(i), 4.0 * i / 7)) for i in range(8)]
    select(empties + [obj], obj)
    bpy.ops.mlsdeform.bind()
    updates, total = 30, 0.0
    lib = []
    for k in range(updates):
        empties[7].location = (0.5 + 0.01 * k, 0.3, 4.0)
        start = time.perf_counter()
        bpy.context.view_layer.update()
        evaluated(obj)
        total += time.perf_counter() - start
        lib.append(obj.mlsdeform.last_ms)
    ms = 1000 * total / updates
    print(
        f"info: {len(obj.data.vertices)} vertices, 8 handles: {ms:.2f} ms per update ({1000 / ms:.0f} updates/s), "
        f"of which the library {np.median(lib):.2f} ms (median)"
    )


try:
    main()
    performance()
except Exception:  # noqa: BLE001 - any exception is a failure of the test
    traceback.print_exc()
    results["failed"] += 1
print(f"{results['passed']} passed, {results['failed']} failed")
sys.exit(1 if results["failed"] else 0)
