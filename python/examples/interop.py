"""Interop: Open3D meshes in and out, and a matplotlib picture of the result. Each part skips with a
message where its package is not installed (Debian: python3-open3d, python3-matplotlib).

    python3 python/examples/interop.py [picture.png]
"""
import sys

import numpy as np

import mlsdeform


def main(argv):
    png = argv[1] if len(argv) > 1 else "mlsdeform-interop.png"
    try:
        import open3d as o3d

        mesh = o3d.geometry.TriangleMesh.create_cylinder(radius=0.3, height=2.0, resolution=40, split=40)
        V = np.asarray(mesh.vertices)
        print(f"open3d {o3d.__version__}: cylinder with {len(V)} vertices")
    except ImportError:
        print("open3d is not installed (Debian: python3-open3d): using a numpy cylinder instead")
        o3d = None
        t, h = np.meshgrid(np.linspace(0, 2 * np.pi, 40, endpoint=False), np.linspace(-1, 1, 41))
        V = np.stack([0.3 * np.cos(t).ravel(), 0.3 * np.sin(t).ravel(), h.ravel()], axis=1)
    ends = [int(np.argmin(V[:, 2])), int(np.argmax(V[:, 2]))]
    P = V[ends]
    Q = P + np.array([[0, 0, 0], [0.8, 0, -0.3]])
    # Two collinear handles leave the twist about their line free: the fit picks the one closest to no turn.
    X = mlsdeform.Deformer(V, points=P).deform(points=Q)
    if o3d is not None:
        mesh.vertices = o3d.utility.Vector3dVector(X)
        mesh.compute_vertex_normals()
        print(f"deformed mesh: {len(mesh.vertices)} vertices, watertight {mesh.is_watertight()}")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (Debian: python3-matplotlib): no picture")
        return 0
    fig = plt.figure(figsize=(6, 4))
    ax = fig.add_subplot(projection="3d")
    ax.scatter(V[:, 0], V[:, 1], V[:, 2], s=0.3, c="0.7", label="rest")
    ax.scatter(X[:, 0], X[:, 1], X[:, 2], s=0.3, c="tab:blue", label="deformed")
    ax.scatter(Q[:, 0], Q[:, 1], Q[:, 2], s=30, c="tab:red", label="handle targets")
    ax.legend(loc="upper left")
    fig.savefig(png, dpi=100)
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
