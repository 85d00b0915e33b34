"""The settings of a bound mesh (Object.mlsdeform): a change rebuilds its session."""
import bpy

from .session import _bound, _sessions, update_object


def _settings_changed(self, context):
    obj = context.object if context else None
    if _bound(obj):
        _sessions.pop(obj.name, None)
        update_object(obj, force=True)


class MLSDeformSettings(bpy.types.PropertyGroup):
    transform: bpy.props.EnumProperty(
        name="Transform",
        items=[
            ("rigid", "Rigid", "As-rigid-as-possible (the paper's)"),
            ("similarity", "Similarity", "Rigid with a uniform scale"),
            ("affine", "Affine", "Any linear map (needs 4 handles spanning 3D)"),
        ],
        default="rigid",
        update=_settings_changed,
    )
    exponent: bpy.props.FloatProperty(
        name="Exponent",
        description="u in the weights |p - v|^-u",
        default=2.0,
        min=1.0,
        max=16.0,
        update=_settings_changed,
    )
    segment_weight: bpy.props.EnumProperty(
        name="Segment weight",
        items=[
            ("paper_constant", "Paper (constant)", "The paper's simplification"),
            ("exact_integral", "Exact integral", "The weight integrated along it"),
        ],
        default="paper_constant",
        update=_settings_changed,
    )
    precision: bpy.props.EnumProperty(
        name="Precision",
        items=[("float", "Float", "32-bit, as Blender stores vertices"), ("double", "Double", "64-bit arithmetic")],
        default="float",
        update=_settings_changed,
    )
    threads: bpy.props.IntProperty(
        name="Threads", description="0: all cores", default=0, min=0, max=256, update=_settings_changed
    )
    arap_iterations: bpy.props.IntProperty(
        name="ARAP iterations",
        description="Surface-ARAP iterations after MLS on the mesh's faces (0: MLS alone)",
        default=0,
        min=0,
        max=1000,
        update=_settings_changed,
    )
    arap_acceleration: bpy.props.EnumProperty(
        name="ARAP acceleration",
        items=[
            ("none", "None", "Plain local/global iterations"),
            ("anderson", "Anderson", "Anderson acceleration: a lower energy in the " "same iterations"),
        ],
        default="anderson",
        update=_settings_changed,
    )
    arap_warm_start: bpy.props.BoolProperty(
        name="ARAP warm start",
        description="Start each update's ARAP iterations from the last result (while "
        "dragging); from MLS after a jump",
        default=True,
        update=_settings_changed,
    )
    last_ms: bpy.props.FloatProperty(name="Last deformation (ms)", default=0.0)
    last_write_ms: bpy.props.FloatProperty(name="Last write to the mesh (ms)", default=0.0)
