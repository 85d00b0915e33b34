"""Deform an OBJ mesh read with the standard library only, and write the result as OBJ.

    python3 python/examples/deform_obj.py data/human_man.obj out.obj

Handles: three vertices of the mesh (the lowest, the highest, and the one furthest along +x); the highest is
lifted by a tenth of the model's height and the one along +x pulled outwards, the lowest stays.
"""
import sys

import numpy as np

import mlsdeform


def read_obj(path):
    vertices, faces = [], []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                vertices.append([float(x) for x in parts[1:4]])
            elif parts[0] == "f":
                faces.append([int(p.split("/")[0]) for p in parts[1:]])
    return np.array(vertices), faces


def write_obj(path, vertices, faces):
    with open(path, "w") as f:
        for v in vertices:
            f.write(f"v {v[0]:.9g} {v[1]:.9g} {v[2]:.9g}\n")
        for face in faces:
            f.write("f " + " ".join(str(i) for i in face) + "\n")


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    V, faces = read_obj(argv[1])
    ids = [int(np.argmin(V[:, 1])), int(np.argmax(V[:, 1])), int(np.argmax(V[:, 0]))]
    P = V[ids]
    height = np.ptp(V[:, 1])
    Q = P.copy()
    Q[1, 1] += 0.1 * height
    Q[2, 0] += 0.1 * height
    d = mlsdeform.Deformer(V, points=P, transform="rigid")
    X = d.deform(points=Q)
    write_obj(argv[2], X, faces)
    print(f"{len(V)} vertices, {len(ids)} handles, instruction set {mlsdeform.active_isa()}: wrote {argv[2]}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
