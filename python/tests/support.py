"""What the Python tests and the hostile campaign (hostile_cases/) share: the seed, random scenes and
rotations."""
import os

import numpy as np

SEED = int(os.environ.get("MLSDEFORM_SEED", "20261124"))


def rng():
    return np.random.default_rng(SEED)


def scene(g, n=400, k=6, s=0):
    V = g.uniform(-1, 1, (n, 3))
    P = g.uniform(-1, 1, (k, 3))
    A = g.uniform(-1, 1, (s, 3))
    B = A + g.uniform(-0.5, 0.5, (s, 3))
    return V, P, A, B


def random_rotation(g):
    q = g.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
