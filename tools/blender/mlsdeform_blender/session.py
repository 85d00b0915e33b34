"""The add-on's state: a session per bound object, rebuilt from what the object stores, and the handlers
that deform every bound mesh when its Empties move, the frame changes, or a file is loaded."""
import importlib.util
import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

# The compiled package: inside the add-on in the legacy zip (Blender 3.4 to 4.1); in the extension (Blender 4.2+),
# a wheel that Blender installs into its extensions' site-packages, imported from there.
if importlib.util.find_spec(".mlsdeform", __package__) is not None:
    from . import mlsdeform
else:
    import mlsdeform


KEY_NAME = "MLS Deform"
PROP_HANDLES = "mlsdeform_handles"  # names of the bound Empties, in handle order
PROP_SEGMENTS = "mlsdeform_segments"  # pairs of indices into the handle list: segment ends
PROP_REST = "mlsdeform_rest"  # rest positions of the handle Empties, local space, flat
PROP_ERROR = "mlsdeform_error"
PROP_MODE = "mlsdeform_mode"  # "vertices" (rest copy in REST_ATTRIBUTE) or "shape_key"
REST_ATTRIBUTE = "mlsdeform_rest"

# Sessions are rebuilt from what the object stores (after reopening a file, after undo): never saved.
_sessions = {}


def _settings(obj):
    return obj.mlsdeform


def _bound(obj):
    return obj is not None and obj.type == "MESH" and PROP_HANDLES in obj


def _rest_vertices(obj):
    """The mesh's rest positions (the rest attribute, or the Basis shape key), float32 (n, 3)."""
    mesh = obj.data
    V = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    if obj.get(PROP_MODE) == "vertices":
        attribute = mesh.attributes.get(REST_ATTRIBUTE)
        if attribute is None:
            raise LookupError(
                f"the attribute '{REST_ATTRIBUTE}' with the rest positions was removed: the rest "
                "pose is lost; unbind keeps the current shape"
            )
        attribute.data.foreach_get("vector", V)
    else:
        mesh.shape_keys.reference_key.data.foreach_get("co", V)
    return V.reshape(-1, 3)


def _write(obj, X):
    mesh = obj.data
    if obj.get(PROP_MODE) == "vertices":
        mesh.vertices.foreach_set("co", X.ravel())
    else:
        key = mesh.shape_keys.key_blocks.get(KEY_NAME) if mesh.shape_keys else None
        if key is None:
            raise LookupError(f"the shape key '{KEY_NAME}' was removed: unbind and bind again")
        key.data.foreach_set("co", X.ravel())
    mesh.update()


def _handle_positions(obj, names):
    """World positions of the named Empties in obj's local space, or raise LookupError naming a missing one."""
    inv = obj.matrix_world.inverted()
    out = np.empty((len(names), 3), dtype=np.float64)
    for i, name in enumerate(names):
        empty = bpy.data.objects.get(name)
        if empty is None:
            raise LookupError(f"handle Empty '{name}' no longer exists: unbind, or undo its deletion")
        out[i] = inv @ empty.matrix_world.translation
    return out


def _split(obj, positions):
    """(points, segments) arrays from all handle positions and the stored segment pairs."""
    pairs = list(obj.get(PROP_SEGMENTS, []))
    pairs = [(pairs[2 * i], pairs[2 * i + 1]) for i in range(len(pairs) // 2)]
    in_segment = {i for pair in pairs for i in pair}
    point_ids = [i for i in range(len(positions)) if i not in in_segment]
    points = positions[point_ids] if point_ids else None
    segments = None
    if pairs:
        segments = (positions[[a for a, _ in pairs]], positions[[b for _, b in pairs]])
    return points, segments


def _session(obj):
    """The cached session of obj, built from the stored rest data when missing or out of date."""
    s = _settings(obj)
    key = (
        obj.name,
        obj.data.name,
        len(obj.data.vertices),
        s.transform,
        s.exponent,
        s.segment_weight,
        s.precision,
        s.threads,
        s.arap_iterations,
        s.arap_acceleration,
        s.arap_warm_start,
    )
    cached = _sessions.get(obj.name)
    if cached is not None and cached["key"] == key:
        return cached
    names = list(obj[PROP_HANDLES])
    rest = np.array(obj[PROP_REST], dtype=np.float64).reshape(-1, 3)
    dtype = np.float32 if s.precision == "float" else np.float64
    V = _rest_vertices(obj).astype(dtype)
    points, segments = _split(obj, rest)
    arap = {}
    if s.arap_iterations > 0:  # the surface for the ARAP iterations: the mesh's polygons as triangles
        obj.data.calc_loop_triangles()
        faces = np.empty(3 * len(obj.data.loop_triangles), dtype=np.int64)
        obj.data.loop_triangles.foreach_get("vertices", faces)
        arap = dict(
            faces=faces.reshape(-1, 3),
            arap_iterations=s.arap_iterations,
            arap_acceleration=s.arap_acceleration,
            arap_warm_start=s.arap_warm_start,
        )
    deformer = mlsdeform.Deformer(
        V,
        points=points,
        segments=segments,
        transform=s.transform,
        exponent=s.exponent,
        segment_weight=s.segment_weight,
        threads=s.threads,
        **arap,
    )
    cached = {"key": key, "deformer": deformer, "names": names, "out": np.empty((len(V), 3), dtype), "last": None}
    _sessions[obj.name] = cached
    return cached


def update_object(obj, force=False):
    """Deform obj for its handles' current positions into its shape key. Returns the time in ms, or None
    where nothing changed. Problems are stored in obj[PROP_ERROR] (shown in the panel), never raised."""
    try:
        session = _session(obj)
        positions = _handle_positions(obj, session["names"])
        if not force and session["last"] is not None and np.array_equal(positions, session["last"]):
            return None
        points, segments = _split(obj, positions)
        start = time.perf_counter()
        X = session["deformer"].deform(points=points, segments=segments, out=session["out"])
        lap = time.perf_counter()
        # Blender stores float32: a double session is rounded once here.
        _write(obj, X if X.dtype == np.float32 else X.astype(np.float32))
        ms = 1000 * (time.perf_counter() - start)
        session["last"] = positions
        _settings(obj).last_ms = 1000 * (lap - start)
        _settings(obj).last_write_ms = ms - 1000 * (lap - start)
        if obj.get(PROP_ERROR):
            del obj[PROP_ERROR]
        return ms
    except (LookupError, ValueError, TypeError, RuntimeError) as e:
        obj[PROP_ERROR] = str(e)
        return None


def _update_all(scene):
    for obj in scene.objects:
        if _bound(obj):
            update_object(obj)


@persistent
def _on_depsgraph(scene, depsgraph=None):
    _update_all(scene)


@persistent
def _on_frame(scene, depsgraph=None):
    _update_all(scene)


@persistent
def _on_load(_):
    _sessions.clear()


@persistent
def _on_undo_redo(scene, _=None):
    # Undo and redo bring back earlier data (Empties, shape keys, bindings): rebuild every session from it.
    _sessions.clear()
    for obj in scene.objects:
        if _bound(obj):
            update_object(obj, force=True)
