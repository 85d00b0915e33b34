"""The operators: Bind, Unbind and Bake (shape keys per frame)."""

import bpy
import numpy as np

from .session import (
    PROP_ERROR,
    PROP_HANDLES,
    PROP_MODE,
    PROP_REST,
    PROP_SEGMENTS,
    KEY_NAME,
    REST_ATTRIBUTE,
    _bound,
    _rest_vertices,
    _session,
    _sessions,
    update_object,
    _handle_positions,
)


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

    # Blender's property annotations are calls, whose strings pyflakes reads as forward references (.flake8).
    frame_start: bpy.props.IntProperty(
        name="Start", default=-1, description="-1: the current pose only"  # noqa: F722,F821
    )
    frame_end: bpy.props.IntProperty(name="End", default=-1)  # noqa: F821

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
