"""A mesh file posed from Python with everything it carries: read with the program's reader, deformed by a
session, its normals carried through each vertex's frame, written with the program's writer: the same bytes as
`mlsdeform deform -m IN -H HANDLES -o OUT` (docs/python.md, "Files").

    python3 deform_file.py [mesh] [handles.json] [out.ply]

Without arguments: data/human_man.obj with normals computed into a PLY first (so that there are normals to carry),
posed by the first frame of data/human_bend.json.
"""
import os
import sys

import mlsdeform
from mlsdeform import files

here = os.path.dirname(os.path.abspath(__file__))
data = os.path.join(here, "..", "..", "data")
if len(sys.argv) > 1:
    mesh_path = sys.argv[1]
else:  # a PLY with normals: the OBJ written with normals computed from its faces
    mesh_path = "human_normals.ply"
    files.write_mesh(mesh_path, files.read_mesh(os.path.join(data, "human_man.obj")), normals="computed")
handles_path = sys.argv[2] if len(sys.argv) > 2 else os.path.join(data, "human_bend.json")
out_path = sys.argv[3] if len(sys.argv) > 3 else "posed.ply"

mesh = files.read_mesh(mesh_path)  # vertices, faces, and every attribute of the file
anim = files.read_handles(handles_path, mesh.vertices)
session = mlsdeform.Deformer(mesh.vertices, **anim.session_arguments())
frames = mesh.frames_for("rigid")  # here {"linear": (n, 3, 3)}: the normals need each vertex's linear part
X = session.deform(**anim.targets(0), **frames)  # fills the frames beside the positions
posed = mesh.deformed(X, **frames)  # normals by L^-T, everything else as read
print(mesh.attributes(out_path))  # {'kept': [...], 'transformed': ['normals (nx ny nz)'], 'dropped': []}
print(f"{files.write_mesh(out_path, posed)} bytes -> {out_path}")
