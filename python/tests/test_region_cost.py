"""A region chosen by index range (scattered over the model) costs no more per frame than its size says: its
border ring, hundreds of fixed handles, is folded into four pseudo-handles where the weights are precomputed
(core/src/deformer/fold.hpp), so the session's table has the caller's handles plus four columns, however long
the ring. Checked on what the session holds (memory_bytes), not on time.
"""
import os

import numpy as np
import pytest

import mlsdeform

HERE = os.path.dirname(os.path.abspath(__file__))


def human():
    V, F = [], []
    with open(os.path.join(HERE, "..", "..", "data", "human_man.obj")) as f:
        for line in f:
            if line.startswith("v "):
                V.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(w.split("/")[0]) - 1 for w in line.split()[1:]]
                F += [[idx[0], idx[i], idx[i + 1]] for i in range(1, len(idx) - 1)]
    return np.array(V, dtype=np.float32), np.array(F)


@pytest.mark.parametrize("size", [3000, 6000])
@pytest.mark.parametrize("with_faces", [False, True])
def test_region_by_index_range_has_a_bounded_table(size, with_faces):
    V, F = human()
    n, k = len(V), 6
    P = V[[1337, 3215, 3386, 411, 5906, 2445]]
    d = mlsdeform.Deformer(V, points=P, faces=F if with_faces else None, region=np.arange(size))
    # Precomputed (the unfolded table of range(6000) was over the 32 MiB budget: on the fly, 40 times slower).
    assert d.uses_precomputed_weights
    # The table holds pad x (k + 4) columns x 16 bytes (float32: omega and A); everything else the session
    # holds is at most 64 bytes per model vertex (p* and vhat: 24 per region vertex; the region's indices,
    # at most 16 per vertex with the vectors' slack; rest and scratch positions, 48; the ring's rest
    # positions, at most 12). One unfolded ring handle would add pad x 16 bytes, beyond the slack of this
    # bound from the third on; these rings have hundreds.
    pad = -(-size // 16) * 16
    assert d.memory_bytes <= pad * (k + 4) * 16 + 64 * n
    # Outside the region, the rest pose bitwise; inside, a deformation.
    Q = P.copy()
    Q[4:] += [0.1, 0.3, 0.2]
    X = d.deform(points=Q)
    assert np.array_equal(X[size:], V[size:])
    assert np.isfinite(X).all() and not np.array_equal(X[:size], V[:size])
