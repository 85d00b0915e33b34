"""Uninitialised objects, a second __init__, pickling and copies."""
import copy
import pickle

import numpy as np

import mlsdeform

from .common import RUNTIME, TYPE, Wrong, add, refused, same
from .references import check_mls
from .scenes import cloud


D_ = mlsdeform.Deformer


def build(args):
    # ---- uninitialised objects, a second __init__, pickling ----
    uninit_calls = {
        "deform()": lambda u: u.deform(),
        "deform(out=)": lambda u: u.deform(out=np.zeros((3, 3))),
        "set_point_target": lambda u: u.set_point_target(0, [0, 0, 0]),
        "set_segment_target": lambda u: u.set_segment_target(0, [0] * 3, [1] * 3),
        "transform_handles": lambda u: u.transform_handles(points=[0]),
        "targets": lambda u: u.targets,
        "vertex_count": lambda u: u.vertex_count,
        "point_count": lambda u: u.point_count,
        "segment_count": lambda u: u.segment_count,
        "dtype": lambda u: u.dtype,
        "memory_bytes": lambda u: u.memory_bytes,
        "uses_precomputed_weights": lambda u: u.uses_precomputed_weights,
        "_time_cpp_deform": lambda u: u._time_cpp_deform(reps=1),
    }
    for name, call in uninit_calls.items():

        def f(g, call=call):
            u = D_.__new__(D_)
            return refused(lambda: call(u), TYPE, ["initialised", "initialized"])

        add("objects", f"uninitialised {name}", f)

    def f(g):
        class Sub(D_):
            pass

        u = Sub.__new__(Sub)
        r = refused(lambda: u.deform(), TYPE, ["initialised"])
        V, P, Q, *_ = cloud(g, n=30, k=4)
        u.__init__(V, points=P)
        check_mls(u.deform(points=Q), V, P, Q, np.float64, what="a subclass initialised after __new__")
        return r

    add("objects", "uninitialised subclass, then __init__", f)
    for how in ("d.__init__", "Deformer.__init__(d)", "subclass calling super().__init__ twice"):

        def f(g, how=how):
            V, P, Q, *_ = cloud(g, n=30, k=4)
            W, R_, *_ = cloud(g, n=12, k=3)
            d = D_(V, points=P)
            want = d.deform(points=Q)
            if how == "d.__init__":
                r = refused(lambda: d.__init__(W, points=R_), RUNTIME, ["initialised"])
            elif how == "Deformer.__init__(d)":
                r = refused(lambda: D_.__init__(d, W, points=R_), RUNTIME, ["initialised"])
            else:

                class Twice(D_):
                    def __init__(self, *a, **k):
                        super().__init__(*a, **k)
                        super().__init__(*a, **k)

                return refused(lambda: Twice(V, points=P), RUNTIME, ["initialised"])
            if d.vertex_count != 30:
                raise Wrong("the refused __init__ changed the session")
            same(d.deform(points=Q), want, "the session after a refused __init__")
            return r

        add("objects", f"second __init__ via {how}", f)

    def f(g):
        class Never(D_):
            def __init__(self):
                pass

        return refused(lambda: Never(), TYPE, ["__init__"])

    add("objects", "subclass that never calls __init__", f)
    add(
        "objects",
        "__init__ with a foreign self",
        lambda g: refused(lambda: D_.__init__(5, np.eye(3), points=np.eye(3)), TYPE, ["incompatible"]),
    )
    add("objects", "deform with a foreign self", lambda g: refused(lambda: D_.deform(object()), TYPE, ["incompatible"]))
    for name, fn in (("pickle", pickle.dumps), ("copy.copy", copy.copy), ("copy.deepcopy", copy.deepcopy)):
        for init in (True, False):

            def f(g, fn=fn, init=init):
                V, P, *_ = cloud(g, n=20, k=4)
                d = D_(V, points=P) if init else D_.__new__(D_)
                return refused(lambda: fn(d), TYPE, ["pickle"])

            add("objects", f"{name} of {'a live' if init else 'an uninitialised'} session", f)

    def f(g):
        V, P, Q, *_ = cloud(g, n=20, k=4)
        X = D_(V, points=P).deform(points=Q)
        same(pickle.loads(pickle.dumps(X)), X, "a result pickles as a plain array")

    add("objects", "results pickle", f)

    def f(g):
        import gc

        V, P, *_ = cloud(g, n=20, k=4)
        d = D_(V, points=P)
        del V, P
        gc.collect()
        if d.vertex_count != 20 or not np.all(np.isfinite(d.deform())):
            raise Wrong("the session depends on the caller's arrays")

    add("objects", "the session owns its data", f)

    def f(g):
        u = D_.__new__(D_)
        if "Deformer" not in repr(u):
            raise Wrong(f"repr {repr(u)!r}")
        del u

    add("objects", "repr and deletion of an uninitialised session", f)
