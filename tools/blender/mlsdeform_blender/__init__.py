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
instead, which Unbind removes. Do not edit the mesh while it is bound: unbind, edit, bind again. Handles live
in the mesh object's local space: an Empty's world position is mapped through the inverse of the mesh object's
world matrix, so moving or rotating the mesh object together with its Empties changes nothing. Shape keys are
evaluated before modifiers: modifiers apply to the deformed mesh.

The add-on by concern: session.py (sessions and handlers), properties.py (the settings), operators.py (Bind,
Unbind, Bake), panel.py (the sidebar and the menu).
"""
import bpy

# The compiled package, as the add-on's tests reach it (mlsdeform_blender.mlsdeform).
from .session import _on_depsgraph, _on_frame, _on_load, _on_undo_redo, _sessions, mlsdeform  # noqa: F401
from .properties import MLSDeformSettings
from .operators import MLSDEFORM_OT_bake, MLSDEFORM_OT_bind, MLSDEFORM_OT_unbind
from .panel import MLSDEFORM_PT_panel, _menu

bl_info = {
    "name": "MLS Deform (mlsdeform)",
    "author": "the mlsdeform authors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > MLS; Object > MLS Deform",
    "description": "As-rigid-as-possible Moving Least Squares posing of a mesh by Empty handles",
    "category": "Animation",
}


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
    for lst, fn in (
        (bpy.app.handlers.depsgraph_update_post, _on_depsgraph),
        (bpy.app.handlers.frame_change_post, _on_frame),
        (bpy.app.handlers.load_post, _on_load),
        (bpy.app.handlers.undo_post, _on_undo_redo),
        (bpy.app.handlers.redo_post, _on_undo_redo),
    ):
        if fn in lst:
            lst.remove(fn)
    bpy.types.VIEW3D_MT_object.remove(_menu)
    del bpy.types.Object.mlsdeform
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    _sessions.clear()
