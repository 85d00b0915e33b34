"""Renders the picture of docs/blender.md headless: the bundled human (data/human_man.obj) posed with the add-on
by Empties at the handles of data/human_bend.json (points and the left-foot segment), rest and posed side by
side, with Cycles on the CPU.

    blender -b --factory-startup --python tools/blender/render_example.py -- build/mlsdeform_blender.zip out.png
"""
import json
import os
import sys

import bpy
import numpy as np

ZIP, OUT = sys.argv[sys.argv.index("--") + 1 :][:2]
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")

bpy.ops.preferences.addon_install(filepath=ZIP, overwrite=True)
bpy.ops.preferences.addon_enable(module="mlsdeform_blender")
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)

verts, faces = [], []
with open(os.path.join(ROOT, "data", "human_man.obj")) as f:
    for line in f:
        p = line.split()
        if p and p[0] == "v":
            verts.append(tuple(float(x) for x in p[1:4]))
        elif p and p[0] == "f":
            faces.append(tuple(int(x.split("/")[0]) - 1 for x in p[1:]))
spec = json.load(open(os.path.join(ROOT, "data", "human_bend.json")))


def human(name, x_offset):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    for poly in mesh.polygons:
        poly.use_smooth = True
    obj = bpy.data.objects.new(name, mesh)
    obj.location.x = x_offset
    obj.rotation_euler = (np.pi / 2, 0, 0)  # the OBJ is y-up
    bpy.context.scene.collection.objects.link(obj)
    return obj


rest = human("rest", -0.6)
posed = human("posed", 0.6)
bpy.context.view_layer.update()
empties = []


def add_empty(name, vertex, target=None):
    e = bpy.data.objects.new(name, None)
    e.location = posed.matrix_world @ posed.data.vertices[vertex].co
    bpy.context.scene.collection.objects.link(e)
    empties.append((e, target))
    return e


for i, p in enumerate(spec["points"]):
    add_empty(f"point{i}", p["vertex"], p.get("target"))
for i, s in enumerate(spec["segments"]):
    a = add_empty(f"seg{i}_a", s["vertices"][0], s.get("targets", [None, None])[0] if "targets" in s else None)
    add_empty(f"seg{i}_b", s["vertices"][1], s.get("targets", [None, None])[1] if "targets" in s else None)
    a["mlsdeform_segment_to"] = f"seg{i}_b"
for o in bpy.context.scene.objects:
    o.select_set(o.type == "EMPTY" or o == posed)
bpy.context.view_layer.objects.active = posed
bpy.context.view_layer.update()
bpy.ops.mlsdeform.bind()
for e, target in empties:
    if target is not None:
        e.location = posed.matrix_world @ __import__("mathutils").Vector(target)
bpy.context.view_layer.update()
if posed.get("mlsdeform_error"):
    raise SystemExit("render_example: " + posed["mlsdeform_error"])

scene = bpy.context.scene
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
cam.location = (3.3, -3.3, 1.2)  # three-quarter view: the forward bend shows
cam.rotation_euler = (np.radians(82), 0, np.radians(45))
scene.collection.objects.link(cam)
scene.camera = cam
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.rotation_euler = (np.radians(50), np.radians(10), np.radians(30))
sun.data.energy = 4.0
scene.collection.objects.link(sun)
world = bpy.data.worlds.new("world")
world.color = (0.35, 0.38, 0.42)
scene.world = world
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 32
scene.cycles.use_denoising = False  # Debian builds Blender without OpenImageDenoise
scene.render.resolution_x, scene.render.resolution_y = 800, 600
scene.render.film_transparent = False
scene.render.filepath = OUT
bpy.ops.render.render(write_still=True)
print(f"render_example: wrote {OUT}; posed mesh: last update {posed.mlsdeform.last_ms:.2f} ms")
