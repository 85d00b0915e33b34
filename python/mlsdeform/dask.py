"""Large jobs over a Dask cluster: the frames of an animation, or a folder of meshes (dataset augmentation).

    from dask.distributed import Client, LocalCluster
    import mlsdeform.dask

    client = Client(LocalCluster(n_workers=2, threads_per_worker=1))    # or Client("tcp://scheduler:8786")
    s = mlsdeform.dask.render_animation(client, "spot.ply.gz", "spot.json", "out/spot.ply")
    print(s)                # frames written, frames/s, the share of the time spent writing files
    s = mlsdeform.dask.deform_meshes(client, "meshes/", "augmented/", output_format=".ply")

render_animation: the mesh is read and the handles file (the program's format, docs/cli.md) resolved once, on
the client; the rest pose is sent to every worker once (Client.scatter(broadcast=True)); each worker builds one
session from it, the first time one of its tasks runs, and keeps it for the rest of the run; the frames are
split into shards, one task each, whose results are the frames' files (OUT_0000.EXT, ... as the program names
them: the number zero-padded to the digits of the largest index, at least 4).

deform_meshes: one task per mesh of a folder: NAME.obj / NAME.ply (or .gz) with its handles file NAME.json beside
it; each frame of the handles file is one output (NAME_0000.EXT, ...; NAME.EXT when the file has no frames).

Every file is written all or nothing (a temporary file beside it, then a rename): a reader never sees part of a
file. Every output path of the run is known before anything is submitted (deform_meshes counts each handles
file's frames on the client): two inputs that would write the same file (meshes `a`, with 3 frames, and `a_0001`)
are refused with ValueError naming both. A run that is interrupted (KeyboardInterrupt: Ctrl-C) or fails on the
client cancels its tasks, stops the running ones before their next frame, removes every file it wrote (as the
program does) and raises again.

A task that fails (an exception: retried `retries` times) or whose worker dies (the scheduler runs it again
elsewhere) writes its files again under the same names, so each output exists exactly once whatever ran twice; the
temporary files of attempts that died are removed at the end. Bad input (a malformed mesh or handles
file) is no transient failure: render_animation raises ValueError before any work, deform_meshes lists the mesh
under `failed` and goes on with the others. Outputs that exist already are refused unless overwrite=True.

Threads: a session uses as many threads as its worker has (Dask's threads_per_worker), unless `threads=` says
otherwise; give each worker process one or more cores (LocalCluster(n_workers=cores, threads_per_worker=1) on one
machine, or `dask worker --nworkers N --nthreads 1 tcp://scheduler:8786` on each machine of a cluster). Every
worker must see the input and output paths (a shared file system).
"""
import asyncio
import json
import os
import threading
import time
import uuid
from dataclasses import dataclass, field

import numpy as np

from . import Deformer
from . import files
from ._files_handles import _strip_comments

__all__ = ["render_animation", "deform_meshes", "Summary"]

# Sessions built on this worker process, by run: each is built once, by the first of the run's tasks to need it.
_sessions = {}
_sessions_lock = threading.Lock()
# Under _sessions_lock as well: the runs stopped on this worker (their tasks write nothing more), the tasks of each
# run running here, and the files each run's tasks wrote here (removed when the run is stopped).
_stopped = set()
_active = {}
_written = {}


@dataclass
class Summary:
    """What a run wrote. `written`: the output paths, in order; `failed`: {input: error message} (deform_meshes);
    `seconds`: wall-clock time of the whole run on the client; `seconds_deform`, `seconds_write`: summed over the
    tasks (the share of the work spent writing files is seconds_write / (seconds_deform + seconds_write));
    `seconds_setup`: of `seconds`, the client's part before the first task (render_animation: reading the mesh,
    resolving the handles, sending the rest pose); `cpu_seconds`: the CPU time of the worker processes while they
    ran the frames (render_animation; with the worker's other threads, if any); `sessions_built`: sessions built
    on the workers (one per worker for render_animation, one per mesh for deform_meshes, more when a worker died
    and its replacement built its own); `temporaries_removed`: files of attempts that died."""

    written: list = field(default_factory=list)
    failed: dict = field(default_factory=dict)
    frames: int = 0
    bytes: int = 0
    seconds: float = 0.0
    seconds_setup: float = 0.0
    cpu_seconds: float = 0.0
    seconds_deform: float = 0.0
    seconds_write: float = 0.0
    tasks: int = 0
    sessions_built: int = 0
    temporaries_removed: int = 0

    @property
    def frames_per_second(self):
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    @property
    def frames_per_second_after_setup(self):
        rest = self.seconds - self.seconds_setup
        return self.frames / rest if rest > 0 else 0.0

    @property
    def write_share(self):
        work = self.seconds_deform + self.seconds_write
        return self.seconds_write / work if work > 0 else 0.0

    def __str__(self):
        text = (
            f"{len(self.written)} files ({self.bytes / 2**20:.1f} MiB) from {self.frames} frames in "
            f"{self.seconds:.2f} s ({self.frames_per_second:.2f} frames/s), {self.tasks} tasks, "
            f"{self.sessions_built} sessions built; of the tasks' time {100 * self.write_share:.0f}% writing "
            "files"
        )
        if self.failed:
            text += f"; {len(self.failed)} failed: " + "; ".join(f"{k}: {v}" for k, v in self.failed.items())
        return text


def _frame_path(out, frame, frame_count):
    """The program's name of frame `frame` of `frame_count` (tools/cli/cmd_deform.cpp, frame_path): "_NNNN" before
    the format extension (".ply", or ".ply.gz"), the number zero-padded to the digits of the largest index, at
    least 4: out_0007.ply of 120 frames, out_00007.ply of 10,001."""
    gz = out[-3:].lower() == ".gz"
    stem = out[:-3] if gz else out
    name = stem[stem.rfind("/") + 1 :]
    dot = name.rfind(".")
    ext = name[dot + 1 :] if dot > 0 else ""
    cut = len(out) - (len(ext) + 1 + (3 if gz else 0) if ext else 0)
    digits = max(4, len(str(max(frame_count - 1, 0))))
    return f"{out[:cut]}_{frame:0{digits}d}{out[cut:]}"


def _output_paths(out, count, animated):
    """The program's naming: OUT.EXT for one output, OUT_0000.EXT, OUT_0001.EXT, ... for an animation."""
    if not animated:
        return [out]
    return [_frame_path(out, i, count) for i in range(count)]


def _frame_count(handles):
    """(frames, animated) of a handles file from its "frames" alone, without resolving it (that needs the mesh,
    read on a worker); None if it is no readable handles file (its task then reports why, writing nothing)."""
    try:
        with open(handles, encoding="utf-8") as f:
            root = json.loads(_strip_comments(f.read()))
    except (OSError, ValueError):
        return None
    if not isinstance(root, dict) or "frames" not in root:
        return 1, False
    frames = root["frames"]
    return (len(frames), True) if isinstance(frames, list) and frames else None


def _check_outputs(paths, overwrite):
    for p in paths:
        folder = os.path.dirname(os.path.abspath(p))
        if not os.path.isdir(folder):
            raise ValueError(f"{p}: cannot write: no folder {folder}")
        if not overwrite and os.path.lexists(p):
            raise ValueError(f"{p}: already exists (overwrite=True replaces it)")
        if os.path.splitext(p)[1].lower() not in (".ply", ".obj", ".npy"):
            raise ValueError(f"{p}: unknown output format (.ply, .obj, .npy)")


def _begin(run):
    """On a worker, as a task of `run` starts: False if the run was stopped (the task then writes nothing)."""
    with _sessions_lock:
        if run in _stopped:
            return False
        _active[run] = _active.get(run, 0) + 1
        return True


def _end(run):
    with _sessions_lock:
        _active[run] -= 1


def _wrote(run, path):
    with _sessions_lock:
        _written.setdefault(run, []).append(path)


async def _stop(run, timeout=120.0):
    """On each worker (Client.run), when the client abandons `run`: its tasks that start from now on write
    nothing, those running stop before their next frame (waited for, up to `timeout` seconds: one frame), and
    every file the run's tasks wrote on this worker is removed. Returns the count removed."""
    with _sessions_lock:
        _stopped.add(run)
    deadline = time.monotonic() + timeout
    while _active.get(run, 0) > 0 and time.monotonic() < deadline:
        await asyncio.sleep(0.01)
    with _sessions_lock:
        paths = _written.pop(run, [])
        _sessions.pop(run, None)
    removed = 0
    for p in dict.fromkeys(paths):
        try:
            os.unlink(p)
            removed += 1
        except OSError:
            pass
    return removed


def _abandon(client, run, futures):
    """The client's part of an interrupted run: its tasks stopped and cancelled, what they wrote removed."""
    removed = sum(client.run(_stop, run).values())
    client.cancel(futures)
    return removed


def _threads(threads):
    if threads is not None:
        return threads
    try:
        from distributed import get_worker

        worker = get_worker()
        return worker.state.nthreads if hasattr(worker, "state") else worker.nthreads
    except (ImportError, ValueError):  # not on a Dask worker: all cores
        return 0


def _render_shard(run, V, faces, rest, options, frames, targets, paths):
    """One task of render_animation: the frames `frames` (with their `targets` and output `paths`) on this
    worker's session of `run`, built from the rest pose if this is the worker's first task of the run. Stops
    before the next frame if the run is stopped (_stop)."""
    if not _begin(run):
        return {"stopped": True}
    try:
        return _render_frames(run, V, faces, rest, options, frames, targets, paths)
    finally:
        _end(run)


def _render_frames(run, V, faces, rest, options, frames, targets, paths):
    built = False
    with _sessions_lock:
        session = _sessions.get(run)
        if session is None:
            opts = dict(options)
            opts["threads"] = _threads(opts.pop("threads", None))
            session = Deformer(V, **rest, **opts)
            _sessions[run] = session
            built = True
    out = np.empty((len(V), 3), dtype=session.dtype)
    seconds_deform = seconds_write = 0.0
    written, nbytes = [], 0
    cpu = time.process_time()
    for frame, target, path in zip(frames, targets, paths):
        if run in _stopped:
            break
        t0 = time.perf_counter()
        session.deform(**target, out=out)
        t1 = time.perf_counter()
        nbytes += files.write_mesh(path, out, faces, tag=run)
        _wrote(run, path)
        seconds_deform += t1 - t0
        seconds_write += time.perf_counter() - t1
        written.append((frame, path))
    return {
        "written": written,
        "bytes": nbytes,
        "deform": seconds_deform,
        "write": seconds_write,
        "built": built,
        "cpu": time.process_time() - cpu,
    }


def _forget(run):
    with _sessions_lock:
        _sessions.pop(run, None)
        _active.pop(run, None)
        _written.pop(run, None)


def render_animation(
    client,
    mesh,
    handles,
    out,
    *,
    frames_per_task=None,
    overwrite=False,
    retries=2,
    dtype=np.float32,
    threads=None,
    **options,
):
    """Renders every frame of the handles file `handles` (the program's format) on the mesh file `mesh`, over
    the Dask `client`'s workers, into the program's file names for `out` (OUT_0000.EXT, ...; .ply, .obj or
    .npy). `options` go to mlsdeform.Deformer (transform=, exponent=, backend=, ...); `dtype` is the session's
    precision. `frames_per_task`: the shard size (default: about four tasks per worker thread). Returns a
    Summary. ValueError for bad input or outputs that exist, before anything is sent to the cluster. Interrupted
    (KeyboardInterrupt) or failed: the tasks are cancelled, the frames written removed, and the exception raised
    again."""
    start = time.perf_counter()
    V, faces = files.read_mesh(mesh, dtype)  # in the session's precision, as the program's --precision
    anim = files.read_handles(handles, V, dtype)
    if "arap_iterations" in options:
        raise ValueError("render_animation: arap_iterations is not supported here (use the program's --arap)")
    paths = _output_paths(out, len(anim.frames), anim.animated)
    _check_outputs(paths, overwrite)
    run = uuid.uuid4().hex
    V = V.astype(dtype, copy=False)
    if threads is not None:
        options["threads"] = threads
    workers = max(1, sum(client.nthreads().values()))
    n = len(anim.frames)
    per_task = frames_per_task or max(1, -(-n // (4 * workers)))
    # The rest pose once to every worker; tasks refer to it and never carry it.
    V_remote, faces_remote = client.scatter([V, faces], broadcast=True)
    setup = time.perf_counter() - start
    futures = []
    summary = Summary(seconds_setup=setup)
    try:  # submitted in the try: an interrupt while submitting cancels what was submitted
        for first in range(0, n, per_task):
            ids = list(range(first, min(n, first + per_task)))
            futures.append(
                client.submit(
                    _render_shard,
                    run,
                    V_remote,
                    faces_remote,
                    anim.session_arguments(),
                    options,
                    ids,
                    [anim.targets(i) for i in ids],
                    [paths[i] for i in ids],
                    pure=False,
                    retries=retries,
                    key=f"mlsdeform-frames-{first}-{run}",
                )
            )
        summary.tasks = len(futures)
        results = client.gather(futures)
    except BaseException:
        _abandon(client, run, futures)
        raise
    finally:
        client.run(_forget, run)
        summary.temporaries_removed = sum(
            files.remove_temporaries(d, run) for d in {os.path.dirname(os.path.abspath(p)) for p in paths}
        )
    written = {}
    for r in results:
        for frame, path in r["written"]:
            written[frame] = path
        summary.bytes += r["bytes"]
        summary.seconds_deform += r["deform"]
        summary.seconds_write += r["write"]
        summary.sessions_built += r["built"]
        summary.cpu_seconds += r["cpu"]
    summary.written = [written[i] for i in range(n)]
    summary.frames = n
    summary.seconds = time.perf_counter() - start
    return summary


def _deform_one(run, mesh, handles, paths, options, dtype):
    """One task of deform_meshes: a mesh and its handles file to its outputs `paths` (computed on the client from
    the handles file's frames). Bad input -> ("failed", message); any other exception propagates (Dask retries the
    task), after removing what this attempt wrote. Stops before the next frame if the run is stopped (_stop)."""
    if not _begin(run):
        return {"stopped": True}
    try:
        return _deform_frames(run, mesh, handles, paths, options, dtype)
    finally:
        _end(run)


def _deform_frames(run, mesh, handles, paths, options, dtype):
    t0 = time.perf_counter()
    try:
        V, faces = files.read_mesh(mesh, dtype)
        anim = files.read_handles(handles, V, dtype)
        if len(paths) != (len(anim.frames) if anim.animated else 1):
            raise ValueError(
                f"{handles}: changed during the run ({len(paths)} outputs counted, now {len(anim.frames)})"
            )
        # A path that exists was there before the run unless this mesh's earlier attempt wrote it.
        _check_outputs(paths, overwrite=True)
        opts = dict(options)
        opts["threads"] = _threads(opts.pop("threads", None))
        if opts.get("arap_iterations"):
            tri = faces.triangles()
            if tri is None:
                raise ValueError(f"{mesh}: arap_iterations needs a triangle mesh")
            opts["faces"] = tri
        session = Deformer(V.astype(dtype, copy=False), **anim.session_arguments(), **opts)
    except ValueError as e:
        return {"failed": str(e)}
    out = np.empty((len(V), 3), dtype=session.dtype)
    seconds_deform, seconds_write, nbytes, written = time.perf_counter() - t0, 0.0, 0, []
    try:
        for i, path in enumerate(paths):
            if run in _stopped:
                break
            t1 = time.perf_counter()
            session.deform(**anim.targets(i), out=out)
            t2 = time.perf_counter()
            nbytes += files.write_mesh(path, out, faces, tag=run)
            _wrote(run, path)
            seconds_deform += t2 - t1
            seconds_write += time.perf_counter() - t2
            written.append(path)
    except BaseException:
        # All or nothing per mesh as well: a retry writes them all again.
        for p in written:
            try:
                os.unlink(p)
            except OSError:
                pass
        raise
    return {"written": written, "bytes": nbytes, "deform": seconds_deform, "write": seconds_write, "frames": len(paths)}


def _claim_outputs(jobs, out_dir, output_format):
    """Every job's output paths, before anything is submitted: {mesh: paths}. ValueError when two inputs would
    write one file (meshes a, with 3 frames, and a_0001: a_0001.EXT twice), naming both."""
    outputs, owner = {}, {}
    for mesh, handles, name in jobs:
        counted = _frame_count(handles)
        out = os.path.join(out_dir, name + output_format)
        paths = [] if counted is None else _output_paths(out, *counted)
        for i, p in enumerate(paths):
            what = f"{mesh} (frame {i} of {handles})" if counted[1] else f"{mesh} ({handles})"
            if p in owner:
                raise ValueError(
                    f"{p}: two inputs would write it: {owner[p]} and {what} (rename one of them, or run them "
                    "into separate folders)"
                )
            owner[p] = what
        outputs[mesh] = paths
    return outputs


def deform_meshes(
    client,
    in_dir,
    out_dir,
    *,
    output_format=".ply",
    overwrite=False,
    retries=2,
    dtype=np.float32,
    threads=None,
    **options,
):
    """Deforms every mesh NAME.obj / NAME.ply (or .gz) of `in_dir` that has a handles file NAME.json beside it,
    one task per mesh over the Dask `client`'s workers, into `out_dir` (NAME_0000.EXT per frame of the handles
    file, or NAME.EXT, named as the program names frames). `options` go to mlsdeform.Deformer (arap_iterations=
    with the mesh's triangles). Returns a Summary whose `failed` maps each mesh that could not be done to the
    reason; the others are written. ValueError, before any work, when two meshes would write one file or (unless
    overwrite=True) an output exists. Interrupted (KeyboardInterrupt): the tasks are cancelled, every file the run
    wrote removed, and the exception raised again."""
    start = time.perf_counter()
    if output_format not in (".ply", ".obj", ".npy"):
        raise ValueError(f"output_format {output_format!r}: .ply, .obj or .npy")
    if not os.path.isdir(out_dir):
        raise ValueError(f"{out_dir}: no such folder")
    jobs = []
    for entry in sorted(os.listdir(in_dir)):
        base = entry[:-3] if entry.endswith(".gz") else entry
        name, ext = os.path.splitext(base)
        if ext.lower() not in (".obj", ".ply"):
            continue
        handles = os.path.join(in_dir, name + ".json")
        if os.path.exists(handles):
            jobs.append((os.path.join(in_dir, entry), handles, name))
    names = [name for _, _, name in jobs]
    if len(set(names)) != len(names):
        raise ValueError(f"{in_dir}: two meshes share a name: {sorted(n for n in names if names.count(n) > 1)}")
    outputs = _claim_outputs(jobs, out_dir, output_format)
    if not overwrite:
        taken = [p for paths in outputs.values() for p in paths if os.path.lexists(p)]
        if taken:
            raise ValueError(f"{taken[0]}: already exists (overwrite=True replaces outputs)")
    if threads is not None:
        options["threads"] = threads
    run = uuid.uuid4().hex
    futures = {}
    summary = Summary()
    try:  # submitted in the try: an interrupt while submitting cancels what was submitted
        for mesh, handles, name in jobs:
            futures[mesh] = client.submit(
                _deform_one,
                run,
                mesh,
                handles,
                outputs[mesh],
                options,
                dtype,
                pure=False,
                retries=retries,
                key=f"mlsdeform-mesh-{name}-{run}",
            )
        summary.tasks = len(futures)
        client.gather(list(futures.values()), errors="skip")
    except BaseException:
        _abandon(client, run, list(futures.values()))
        raise
    finally:
        client.run(_forget, run)
        summary.temporaries_removed = files.remove_temporaries(out_dir, run)
    for mesh, fut in futures.items():
        if fut.status != "finished":
            summary.failed[mesh] = f"{type(fut.exception()).__name__}: {fut.exception()}"
            continue
        r = fut.result()
        if "failed" in r:
            summary.failed[mesh] = r["failed"]
            continue
        summary.written += r["written"]
        summary.frames += r["frames"]
        summary.bytes += r["bytes"]
        summary.seconds_deform += r["deform"]
        summary.seconds_write += r["write"]
        summary.sessions_built += 1
    summary.seconds = time.perf_counter() - start
    return summary
