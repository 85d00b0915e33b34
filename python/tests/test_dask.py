"""mlsdeform.dask on a LocalCluster of two worker processes: every output exactly once and bitwise equal to the same
session run directly, one session per worker, outputs refused unless overwrite=True, a worker killed in the middle
of a task, a write that fails once and is retried, bad input reported per mesh, two inputs that would write one
file refused, an interrupted run leaving nothing, frames named as the program names them."""
import logging
import os
import shutil
import subprocess
import sys
import uuid

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
        got = np.load(path) if ext == ".npy" else files.read_mesh(path).vertices
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


def half_written(path, tag, head):
    """A temporary file as write_atomically names it (`.NAME.TAG.*.tmp`), holding `head`: the part of a frame a
    writer that died or failed had written."""
    folder, name = os.path.split(os.path.abspath(path))
    f = open(os.path.join(folder, f".{name}.{tag}.{uuid.uuid4().hex}.tmp"), "wb")
    f.write(head)
    f.flush()
    return f


def die_in_second_write(marker):
    """On a worker: the first worker to write its second frame dies in the middle of that write (os._exit: no
    clean-up, a temporary file half written, its task unfinished); the marker file names the frame."""
    real = files.write_atomically
    count = [0]

    def write_atomically(path, data, tag=""):
        count[0] += 1
        if count[0] == 2:
            try:
                fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                return real(path, data, tag)
            os.write(fd, path.encode())
            os.close(fd)
            half_written(path, tag, data[: len(data) // 2])
            os._exit(1)
        return real(path, data, tag)

    files.write_atomically = write_atomically


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
    b.ply fails half-way: a temporary file half written (removed by the writer, as write_atomically does), then
    OSError."""
    real = files.write_atomically

    def write_atomically(path, data, tag=""):
        if os.path.basename(path) not in ("a_0001.ply", "b.ply"):
            return real(path, data, tag)
        try:
            fd = os.open(os.path.join(marker_dir, os.path.basename(path)), os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            return real(path, data, tag)
        os.close(fd)
        f = half_written(path, tag, data[:40])
        f.close()
        os.unlink(f.name)
        raise OSError("simulated: the disk went away")

    files.write_atomically = write_atomically


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
        assert np.array_equal(files.read_mesh(str(out / f"a_{i:04d}.ply")).vertices, X)
    assert np.array_equal(
        files.read_mesh(str(out / "b.ply")).vertices, direct(str(src / "b.obj"), str(src / "b.json"))[0]
    )
    assert s.frames == 4 and s.sessions_built == 2 and len(s.written) == 4
    with pytest.raises(ValueError, match="already exists"):
        mdask.deform_meshes(client, str(src), str(out))


def program():
    path = os.environ.get("MLSDEFORM_CLI") or shutil.which("mlsdeform")
    if not path or not os.path.exists(path):
        pytest.skip("the mlsdeform program is not found (MLSDEFORM_CLI, or on PATH)")
    return path


@pytest.mark.parametrize("frames", [3, 10000, 10001])
def test_frame_names_as_the_program(tmp_path, frames):
    """Dask names frames by the program's rule: the number zero-padded to the digits of the largest index, at
    least 4 (a_00000 .. a_10000 for 10,001 frames)."""
    import json

    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n")
    spec = {
        "points": [{"vertex": 0}, {"vertex": 1}],
        "frames": [{"points": [None, [1, 0, 1e-3 * i]]} for i in range(frames)],
    }
    (tmp_path / "h.json").write_text(json.dumps(spec))
    out = tmp_path / "out"
    out.mkdir()
    run = subprocess.run(
        [
            program(),
            "deform",
            "-q",
            "-m",
            str(tmp_path / "m.obj"),
            "-H",
            str(tmp_path / "h.json"),
            "-o",
            str(out / "a.obj"),
        ],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr
    program_names = sorted(os.listdir(out))
    dask_names = sorted(os.path.basename(p) for p in mdask._output_paths(str(out / "a.obj"), frames, True))
    assert len(program_names) == frames and dask_names == program_names
    if frames == 10001:
        assert dask_names[0] == "a_00000.obj" and dask_names[-1] == "a_10000.obj"


def test_deform_meshes_refuses_two_inputs_writing_one_output(client, tmp_path):
    import json

    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    out.mkdir()
    V, F = files.read_mesh(HUMAN)
    spec = json.load(open(BEND))
    spec["frames"] = spec["frames"][:3]
    for name in ("a", "a_0001"):
        files.write_mesh(str(src / f"{name}.ply"), V, F)
    (src / "a.json").write_text(json.dumps(spec))  # a_0000 .. a_0002
    (src / "a_0001.json").write_text(json.dumps({"points": [{"vertex": 0}]}))  # a_0001
    with pytest.raises(ValueError) as e:
        mdask.deform_meshes(client, str(src), str(out), overwrite=True)
    message = str(e.value)
    assert str(out / "a_0001.ply") in message and str(src / "a.ply") in message and str(src / "a_0001.ply") in message
    assert os.listdir(out) == [], "refused before any work"


def slow_writes(seconds):
    """On a worker: every write takes `seconds` longer."""
    import time

    real = files.write_atomically

    def write_atomically(path, data, tag=""):
        time.sleep(seconds)
        return real(path, data, tag)

    files.write_atomically = write_atomically


def interrupt_when(folder, count):
    """Ctrl-C (SIGINT to the main thread) once `folder` holds `count` files."""
    import signal
    import threading
    import time

    def watch():
        deadline = time.monotonic() + 60
        while len(os.listdir(folder)) < count and time.monotonic() < deadline:
            time.sleep(0.01)
        signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)

    t = threading.Thread(target=watch, daemon=True)
    t.start()
    return t


@pytest.mark.parametrize("call", ["render_animation", "deform_meshes"])
def test_interrupted_run_cancels_and_removes_what_it_wrote(client, tmp_path, call):
    """Ctrl-C during a run: KeyboardInterrupt, the queued tasks cancelled and the running ones stopped (nothing
    written after), and every file the run wrote removed, as the program does."""
    import time

    out = tmp_path / "out"
    out.mkdir()
    handles = long_animation(tmp_path / "long.json", 60)
    client.run(slow_writes, 0.05)
    watcher = interrupt_when(out, 4)
    with pytest.raises(KeyboardInterrupt):
        if call == "render_animation":
            mdask.render_animation(client, HUMAN, handles, str(out / "f.npy"), frames_per_task=3)
        else:
            src = tmp_path / "in"
            src.mkdir()
            for name in ("a", "b", "c"):
                os.symlink(HUMAN, src / f"{name}.obj")
                os.symlink(handles, src / f"{name}.json")
            mdask.deform_meshes(client, str(src), str(out), output_format=".npy")
        time.sleep(60)  # not reached: the interrupt comes first
    watcher.join()
    assert os.listdir(out) == []
    time.sleep(1.0)
    assert os.listdir(out) == [], "tasks went on writing after the interrupt"
