"""mlsdeform.dask on a LocalCluster of two worker processes: every output exactly once and bitwise equal to the same
session run directly, one session per worker, outputs refused unless overwrite=True, a worker killed in the middle
of a task, a write that fails once and is retried, bad input reported per mesh."""
import logging
import os
import sys

import numpy as np
import pytest

import mlsdeform
from mlsdeform import files

pytest.importorskip("dask")
distributed = pytest.importorskip("distributed")
import cloudpickle  # noqa: E402 - distributed's own dependency

import mlsdeform.dask as mdask  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "data")
HUMAN = os.path.join(DATA, "human_man.obj")
BEND = os.path.join(DATA, "human_bend.json")

# The workers unpickle this module's plugin and hooks by value: it is not importable there.
cloudpickle.register_pickle_by_value(sys.modules[__name__])


@pytest.fixture
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=logging.ERROR
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def direct(mesh, handles):
    V, _ = files.read_mesh(mesh)
    anim = files.read_handles(handles, V)
    d = mlsdeform.Deformer(V, **anim.session_arguments())
    return [d.deform(**anim.targets(i)).copy() for i in range(len(anim.frames))]


def long_animation(path, frames):
    """human_bend.json's handles with `frames` frames (its own, repeated with growing offsets)."""
    import json

    spec = json.load(open(BEND))
    base = spec["frames"]
    spec["frames"] = [
        {
            "points": [
                p if p is None else [p[0], p[1], p[2] + 0.001 * (i // len(base))] for p in base[i % len(base)]["points"]
            ]
        }
        for i in range(frames)
    ]
    path.write_text(json.dumps(spec))
    return str(path)


def check_frames(folder, stem, ext, want):
    """Exactly the frames stem_0000.ext ... (no other file, no temporary), each bitwise equal to want[i]."""
    names = sorted(os.listdir(folder))
    assert names == [f"{stem}_{i:04d}{ext}" for i in range(len(want))], names
    for i, X in enumerate(want):
        path = os.path.join(folder, names[i])
        got = np.load(path) if ext == ".npy" else files.read_mesh(path)[0]
        assert np.array_equal(got, X), f"frame {i}"


def test_render_animation(client, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    s = mdask.render_animation(client, HUMAN, BEND, str(out / "bent.ply"), frames_per_task=2)
    check_frames(out, "bent", ".ply", direct(HUMAN, BEND))
    assert s.frames == 24 and s.tasks == 12 and len(s.written) == 24 and s.temporaries_removed == 0
    # One session per worker, built once from the rest pose: never one per task.
    assert 1 <= s.sessions_built <= 2
    assert 0 < s.write_share < 1 and s.bytes == sum(os.path.getsize(p) for p in s.written)
    with pytest.raises(ValueError, match="already exists"):
        mdask.render_animation(client, HUMAN, BEND, str(out / "bent.ply"))
    s = mdask.render_animation(client, HUMAN, BEND, str(out / "bent.ply"), overwrite=True)
    check_frames(out, "bent", ".ply", direct(HUMAN, BEND))


def die_in_second_write(marker):
    """On a worker: the first worker to write its second frame dies in the middle of that write (os._exit: no
    clean-up, a temporary file half written, its task unfinished); the marker file names the frame."""
    real = files.write_mesh
    count = [0]

    def write_mesh(path, vertices, faces=None, tag=""):
        count[0] += 1
        if count[0] == 2:
            try:
                fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                return real(path, vertices, faces, tag)
            os.write(fd, path.encode())
            os.close(fd)

            def half_then_die(f):
                f.write(b"\x93NUMPY half a frame")
                f.flush()
                os._exit(1)

            files.write_atomically(path, half_then_die, tag)
        return real(path, vertices, faces, tag)

    files.write_mesh = write_mesh


def test_worker_killed_mid_run(client, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    marker = tmp_path / "killed"
    handles = long_animation(tmp_path / "long.json", 60)
    client.run(die_in_second_write, str(marker))
    s = mdask.render_animation(client, HUMAN, handles, str(out / "f.npy"), frames_per_task=3)
    assert marker.exists(), "no worker was killed"
    # Every frame exactly once, whole and right, whatever the dead worker had written; its temporary file gone.
    check_frames(out, "f", ".npy", direct(HUMAN, handles))
    assert s.frames == 60 and len(s.written) == 60 and s.temporaries_removed == 1


def flaky_writes(marker_dir):
    """On a worker: the first write of a_0001.ply (after a_0000.ply, which the failed attempt must remove) and of
    b.ply fails half-way: a temporary file half written, then OSError."""
    real = files.write_mesh

    def write_mesh(path, vertices, faces=None, tag=""):
        if os.path.basename(path) not in ("a_0001.ply", "b.ply"):
            return real(path, vertices, faces, tag)
        try:
            fd = os.open(os.path.join(marker_dir, os.path.basename(path)), os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            return real(path, vertices, faces, tag)
        os.close(fd)

        def half(f):
            f.write(b"ply\nformat binary_little_endian 1.0\n")
            raise OSError("simulated: the disk went away")

        files.write_atomically(path, half, tag)

    files.write_mesh = write_mesh


def test_deform_meshes(client, tmp_path):
    import json

    src, out, markers = tmp_path / "in", tmp_path / "out", tmp_path / "markers"
    for d in (src, out, markers):
        d.mkdir()
    V, F = files.read_mesh(HUMAN)
    files.write_mesh(str(src / "a.ply"), V, F)  # binary PLY, the animation
    spec = json.load(open(BEND))
    spec["frames"] = spec["frames"][:3]
    (src / "a.json").write_text(json.dumps(spec))
    files.write_mesh(str(src / "b.obj"), V[::2].copy(), None)  # a point cloud, one pose
    (src / "b.json").write_text(json.dumps({"points": [{"vertex": 0}, {"vertex": 100, "offset": [0, 0.1, 0]}]}))
    files.write_mesh(str(src / "c.obj"), V, F)  # bad handles
    (src / "c.json").write_text(json.dumps({"points": [{"vertex": 99999}]}))
    (src / "d.obj").write_text("v 0 0 0\n")  # no handles file: not a job
    client.run(flaky_writes, str(markers))
    s = mdask.deform_meshes(client, str(src), str(out))
    assert (
        list(s.failed) == [str(src / "c.obj")]
        and "/points/0/vertex: vertex index 99999" in s.failed[str(src / "c.obj")]
    )
    assert sorted(os.listdir(out)) == ["a_0000.ply", "a_0001.ply", "a_0002.ply", "b.ply"]
    assert sorted(os.listdir(markers)) == ["a_0001.ply", "b.ply"], "the two writes failed once, then retried"
    for i, X in enumerate(direct(str(src / "a.ply"), str(src / "a.json"))):
        assert np.array_equal(files.read_mesh(str(out / f"a_{i:04d}.ply"))[0], X)
    assert np.array_equal(files.read_mesh(str(out / "b.ply"))[0], direct(str(src / "b.obj"), str(src / "b.json"))[0])
    assert s.frames == 4 and s.sessions_built == 2 and len(s.written) == 4
    with pytest.raises(ValueError, match="already exists"):
        mdask.deform_meshes(client, str(src), str(out))
