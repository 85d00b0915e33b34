"""The sidebar panel (View3D > Sidebar > MLS) and the Object menu's entries."""
import bpy

from .session import PROP_ERROR, PROP_HANDLES, _bound


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
