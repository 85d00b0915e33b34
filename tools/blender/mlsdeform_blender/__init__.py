"""mlsdeform for Blender: as-rigid-as-possible MLS posing of a mesh by Empty handles.

Workflow: select a mesh object and one or more Empties (the handles), make the mesh active, then
Object > MLS Deform > Bind (bpy.ops.mlsdeform.bind()). Where the Empties are at that moment is their rest
position; moving them later deforms the mesh live, during animation playback too. An Empty with the custom
property "mlsdeform_segment_to" naming another bound Empty is a segment handle from itself to that Empty
(the partner is then no point handle of its own).

Where the deformation goes: a mesh without shape keys gets the deformed positions in its vertices, while Bind
keeps the rest positions in the point attribute "mlsdeform_rest" (an exact copy), from which Unbind restores
the mesh exactly (this is the fast path: writing vertices costs about 0.4 ms per 10^5 vertices, a shape key
about 8 ms). A mesh that already has shape keys gets a shape key "MLS Deform" (value 1) on top of its Basis
instead, which Unbind removes. Do not edit the mesh while it is bound: unbind, edit, bind again. Handles live in the mesh object's local space: an Empty's world position is mapped
through the inverse of the mesh object's world matrix, so moving or rotating the mesh object together with its
Empties changes nothing. Shape keys are evaluated before modifiers: modifiers apply to the deformed mesh.
"""

bl_info = {
    "name": "MLS Deform (mlsdeform)",
    "author": "the mlsdeform authors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > MLS; Object > MLS Deform",
    "description": "As-rigid-as-possible Moving Least Squares posing of a mesh by Empty handles",
    "category": "Animation",
}

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
PROP_HANDLES = "mlsdeform_handles"      # names of the bound Empties, in handle order
PROP_SEGMENTS = "mlsdeform_segments"    # pairs of indices into the handle list: segment ends
PROP_REST = "mlsdeform_rest"            # rest positions of the handle Empties, local space, flat
PROP_ERROR = "mlsdeform_error"
PROP_MODE = "mlsdeform_mode"            # "vertices" (rest copy in REST_ATTRIBUTE) or "shape_key"
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
            raise LookupError(f"the attribute '{REST_ATTRIBUTE}' with the rest positions was removed: the rest "
                              "pose is lost; unbind keeps the current shape")
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
    key = (obj.name, obj.data.name, len(obj.data.vertices), s.transform, s.exponent, s.segment_weight,
           s.precision, s.threads, s.arap_iterations, s.arap_acceleration, s.arap_warm_start)
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
        arap = dict(faces=faces.reshape(-1, 3), arap_iterations=s.arap_iterations,
                    arap_acceleration=s.arap_acceleration, arap_warm_start=s.arap_warm_start)
    deformer = mlsdeform.Deformer(V, points=points, segments=segments, transform=s.transform,
                                  exponent=s.exponent, segment_weight=s.segment_weight, threads=s.threads, **arap)
    cached = {"key": key, "deformer": deformer, "names": names, "out": np.empty((len(V), 3), dtype),
              "last": None}
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


def _settings_changed(self, context):
    obj = context.object if context else None
    if _bound(obj):
        _sessions.pop(obj.name, None)
        update_object(obj, force=True)


class MLSDeformSettings(bpy.types.PropertyGroup):
    transform: bpy.props.EnumProperty(
        name="Transform", items=[("rigid", "Rigid", "As-rigid-as-possible (the paper's)"),
                                 ("similarity", "Similarity", "Rigid with a uniform scale"),
                                 ("affine", "Affine", "Any linear map (needs 4 handles spanning 3D)")],
        default="rigid", update=_settings_changed)
    exponent: bpy.props.FloatProperty(name="Exponent", description="u in the weights |p - v|^-u", default=2.0,
                                      min=1.0, max=16.0, update=_settings_changed)
    segment_weight: bpy.props.EnumProperty(
        name="Segment weight", items=[("paper_constant", "Paper (constant)", "The paper's simplification"),
                                      ("exact_integral", "Exact integral", "The weight integrated along it")],
        default="paper_constant", update=_settings_changed)
    precision: bpy.props.EnumProperty(
        name="Precision", items=[("float", "Float", "32-bit, as Blender stores vertices"),
                                 ("double", "Double", "64-bit arithmetic")],
        default="float", update=_settings_changed)
    threads: bpy.props.IntProperty(name="Threads", description="0: all cores", default=0, min=0, max=256,
                                   update=_settings_changed)
    arap_iterations: bpy.props.IntProperty(
        name="ARAP iterations", description="Surface-ARAP iterations after MLS on the mesh's faces (0: MLS alone)",
        default=0, min=0, max=1000, update=_settings_changed)
    arap_acceleration: bpy.props.EnumProperty(
        name="ARAP acceleration", items=[("none", "None", "Plain local/global iterations"),
                                         ("anderson", "Anderson", "Anderson acceleration: a lower energy in the "
                                          "same iterations")],
        default="anderson", update=_settings_changed)
    arap_warm_start: bpy.props.BoolProperty(
        name="ARAP warm start", description="Start each update's ARAP iterations from the last result (while "
        "dragging); from MLS after a jump", default=True, update=_settings_changed)
    last_ms: bpy.props.FloatProperty(name="Last deformation (ms)", default=0.0)
    last_write_ms: bpy.props.FloatProperty(name="Last write to the mesh (ms)", default=0.0)


def _selection(context):
    obj = context.active_object
    if obj is None or obj.type != "MESH":
        return None, [], "Make a mesh object active (select the Empties, then the mesh last)"
    empties = [o for o in context.selected_objects if o.type == "EMPTY"]
    if not empties:
        return obj, [], "Select one or more Empties as handles together with the mesh"
    return obj, sorted(empties, key=lambda o: o.name), None


class MLSDEFORM_OT_bind(bpy.types.Operator):
    """Bind the active mesh to the selected Empties: their current positions are the rest pose"""
    bl_idname = "mlsdeform.bind"
    bl_label = "Bind"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj, empties, problem = _selection(context)
        if problem:
            self.report({"ERROR"}, problem)
            return {"CANCELLED"}
        if _bound(obj):
            _unbind(obj)
        names = [e.name for e in empties]
        pairs = []
        for i, e in enumerate(empties):
            partner = e.get("mlsdeform_segment_to")
            if partner:
                if partner not in names:
                    self.report({"ERROR"}, f"'{e.name}' is a segment to '{partner}', which is not selected")
                    return {"CANCELLED"}
                pairs += [i, names.index(partner)]
        obj[PROP_HANDLES] = names
        obj[PROP_SEGMENTS] = pairs
        obj[PROP_REST] = _handle_positions(obj, names).ravel().tolist()
        mesh = obj.data
        if mesh.shape_keys is None:
            obj[PROP_MODE] = "vertices"
            if REST_ATTRIBUTE in mesh.attributes:
                mesh.attributes.remove(mesh.attributes[REST_ATTRIBUTE])
            co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
            mesh.vertices.foreach_get("co", co)
            mesh.attributes.new(REST_ATTRIBUTE, "FLOAT_VECTOR", "POINT").data.foreach_set("vector", co)
        else:
            obj[PROP_MODE] = "shape_key"
            key = obj.shape_key_add(name=KEY_NAME, from_mix=False)
            key.value = 1.0
        _sessions.pop(obj.name, None)
        try:
            _session(obj)
        except (ValueError, TypeError) as e:
            _unbind(obj)
            self.report({"ERROR"}, f"mlsdeform: {e}")
            return {"CANCELLED"}
        update_object(obj, force=True)
        self.report({"INFO"}, f"Bound '{obj.name}' ({len(mesh.vertices)} vertices) to {len(names)} Empties")
        return {"FINISHED"}


def _unbind(obj):
    _sessions.pop(obj.name, None)
    mesh = obj.data
    attribute = mesh.attributes.get(REST_ATTRIBUTE)
    if obj.get(PROP_MODE) == "vertices" and attribute is not None:
        co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        attribute.data.foreach_get("vector", co)
        mesh.vertices.foreach_set("co", co)  # the exact rest positions
        mesh.attributes.remove(attribute)
    if mesh.shape_keys is not None:
        key = mesh.shape_keys.key_blocks.get(KEY_NAME)
        if key is not None:
            obj.shape_key_remove(key)
    for prop in (PROP_HANDLES, PROP_SEGMENTS, PROP_REST, PROP_MODE, PROP_ERROR):
        if prop in obj:
            del obj[prop]
    mesh.update()


class MLSDEFORM_OT_unbind(bpy.types.Operator):
    """Remove the binding and its shape key: the mesh is exactly as before Bind"""
    bl_idname = "mlsdeform.unbind"
    bl_label = "Unbind"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = context.active_object
        if not _bound(obj):
            self.report({"ERROR"}, "The active object is not bound")
            return {"CANCELLED"}
        _unbind(obj)
        return {"FINISHED"}


def _to_shape_key_mode(obj):
    """From deformed vertices (rest copy in the attribute) to a rest Basis plus the "MLS Deform" key."""
    mesh = obj.data
    rest = _rest_vertices(obj).ravel()
    mesh.vertices.foreach_set("co", rest)
    mesh.attributes.remove(mesh.attributes[REST_ATTRIBUTE])
    obj.shape_key_add(name="Basis", from_mix=False)
    obj.shape_key_add(name=KEY_NAME, from_mix=False).value = 1.0
    obj[PROP_MODE] = "shape_key"
    _sessions.pop(obj.name, None)
    mesh.update()


class MLSDEFORM_OT_bake(bpy.types.Operator):
    """Write the current pose, or each frame of a range, as shape keys ("MLS f0001", ...)"""
    bl_idname = "mlsdeform.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER", "UNDO"}

    frame_start: bpy.props.IntProperty(name="Start", default=-1, description="-1: the current pose only")
    frame_end: bpy.props.IntProperty(name="End", default=-1)

    def execute(self, context):
        obj = context.active_object
        if not _bound(obj):
            self.report({"ERROR"}, "The active object is not bound")
            return {"CANCELLED"}
        if obj.get(PROP_MODE) == "vertices":
            _to_shape_key_mode(obj)  # baked keys need the rest pose as Basis, and then a key of our own
        scene = context.scene
        last = max(self.frame_end, self.frame_start)
        frames = [None] if self.frame_start < 0 else list(range(self.frame_start, last + 1))
        current = scene.frame_current
        baked = 0
        for f in frames:
            if f is not None:
                scene.frame_set(f)
            update_object(obj, force=True)
            if obj.get(PROP_ERROR):
                self.report({"ERROR"}, obj[PROP_ERROR])
                break
            co = np.ascontiguousarray(_sessions[obj.name]["out"], dtype=np.float32).ravel()
            key = obj.shape_key_add(name=f"MLS f{f:04d}" if f is not None else "MLS pose", from_mix=False)
            key.data.foreach_set("co", co)
            key.value = 0.0
            baked += 1
        if frames != [None]:
            scene.frame_set(current)
        self.report({"INFO"}, f"Baked {baked} shape key(s)")
        return {"FINISHED"}


class MLSDEFORM_PT_panel(bpy.types.Panel):
    bl_label = "MLS Deform"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "MLS"

    def draw(self, context):
        layout = self.layout
        obj = context.active_object
        if obj is None or obj.type != "MESH":
            layout.label(text="Select Empties, then a mesh (active)")
            return
        s = obj.mlsdeform
        for prop in ("transform", "exponent", "segment_weight", "precision", "threads", "arap_iterations"):
            layout.prop(s, prop)
        if s.arap_iterations > 0:
            layout.prop(s, "arap_acceleration")
            layout.prop(s, "arap_warm_start")
        row = layout.row()
        row.operator("mlsdeform.bind")
        row.operator("mlsdeform.unbind")
        layout.operator("mlsdeform.bake")
        if _bound(obj):
            layout.label(text=f"{len(obj.data.vertices)} vertices, {len(obj[PROP_HANDLES])} handles")
            layout.label(text=f"last update {s.last_ms:.2f} ms (+ {s.last_write_ms:.2f} ms to the mesh)")
            total = s.last_ms + s.last_write_ms
            if total > 0:  # the update rate the handles can be dragged at, ARAP included
                rate = f"{1000 / total:.0f} updates/s"
                layout.label(text=rate + (f" with {s.arap_iterations} ARAP iterations" if s.arap_iterations else ""))
            if obj.get(PROP_ERROR):
                layout.label(text=obj[PROP_ERROR], icon="ERROR")


def _menu(self, context):
    self.layout.separator()
    self.layout.operator("mlsdeform.bind", text="MLS Deform: Bind")
    self.layout.operator("mlsdeform.unbind", text="MLS Deform: Unbind")


_classes = (MLSDeformSettings, MLSDEFORM_OT_bind, MLSDEFORM_OT_unbind, MLSDEFORM_OT_bake, MLSDEFORM_PT_panel)


def register():
    for c in _classes:
        bpy.utils.register_class(c)
    bpy.types.Object.mlsdeform = bpy.props.PointerProperty(type=MLSDeformSettings)
    bpy.types.VIEW3D_MT_object.append(_menu)
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph)
    bpy.app.handlers.frame_change_post.append(_on_frame)
    bpy.app.handlers.load_post.append(_on_load)
    bpy.app.handlers.undo_post.append(_on_undo_redo)
    bpy.app.handlers.redo_post.append(_on_undo_redo)


def unregister():
    for lst, fn in ((bpy.app.handlers.depsgraph_update_post, _on_depsgraph),
                    (bpy.app.handlers.frame_change_post, _on_frame), (bpy.app.handlers.load_post, _on_load),
                    (bpy.app.handlers.undo_post, _on_undo_redo), (bpy.app.handlers.redo_post, _on_undo_redo)):
        if fn in lst:
            lst.remove(fn)
    bpy.types.VIEW3D_MT_object.remove(_menu)
    del bpy.types.Object.mlsdeform
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    _sessions.clear()
