"""Large jobs over a Dask cluster: the frames of an animation, or a folder of meshes (dataset augmentation).

    from dask.distributed import Client, LocalCluster
    import mlsdeform.dask

    client = Client(LocalCluster(n_workers=2, threads_per_worker=1))    # or Client("tcp://scheduler:8786")
    s = mlsdeform.dask.render_animation(client, "spot.ply.gz", "spot.json", "out/spot.ply")
    print(s)                # frames written, frames/s, the share of the time spent writing files
    s = mlsdeform.dask.deform_meshes(client, "meshes/", "augmented/", output_format=".ply")

Both run the program's own `deform` on every worker (mlsdeform.files.DeformJob: the files library that the
program is built on), so every output is byte for byte the file `mlsdeform deform` writes for the same mesh,
handles file and options, with every attribute of the input kept or carried through the frames (normals,
splats, colours, custom properties), in every format the program writes (.obj, .off, .ply, their .gz, .npy).

render_animation: the mesh and the handles file (the program's format, docs/cli.md) are read and checked once on
the client; each worker builds one job from the files (reads them, builds its session) the first time one of its
tasks runs, and keeps it for the rest of the run; the frames are split into shards, one task each, whose results
are the frames' files (OUT_0000.EXT, ... as the program names them: the number zero-padded to the digits of the
largest index, at least 4).

deform_meshes: one task per mesh of a folder: NAME.EXT in any format the program reads (.obj, .off, .ply, their
.gz, and the splat formats) with its handles file NAME.json beside it; each frame of the handles file is one
output (NAME_0000.EXT, ...; NAME.EXT when the file has no frames).

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

`options` are the program's: Deformer's keyword arguments (transform=, exponent=, method=, weight_storage=,
arap_iterations=, ...) and its file options normals=, ply_ascii=, output_type=, strict_attributes= (a dropped
attribute is named in Summary.dropped, or refused with strict_attributes=True).

Threads: a session uses as many threads as its worker has (Dask's threads_per_worker), unless `threads=` says
otherwise; give each worker process one or more cores (LocalCluster(n_workers=cores, threads_per_worker=1) on one
machine, or `dask worker --nworkers N --nthreads 1 tcp://scheduler:8786` on each machine of a cluster). Every
worker must see the input and output paths (a shared file system).
"""
import os
import threading
import time
import uuid

import numpy as np

from . import files
from ._dask_runs import Summary, _abandon, _begin, _end, _forget, _job, _sessions, _sessions_lock, _stopped, _wrote
from ._mlsdeform import _check_output_format, _handles_frames, _mesh_format

__all__ = ["render_animation", "deform_meshes", "Summary"]

Summary.__module__ = __name__  # pickles and help() name it by this public module


def _output_paths(out, count, animated):
    """The program's naming: OUT.EXT for one output, OUT_0000.EXT, OUT_0001.EXT, ... for an animation."""
    if not animated:
        return [out]
    return [files.frame_path(out, i, count) for i in range(count)]


def _frame_count(handles):
    """(frames, animated) of a handles file, checked on its own (not yet against its mesh, read on a worker);
    None if it is no readable handles file (its task then reports why, writing nothing)."""
    try:
        return _handles_frames(handles)
    except (OSError, ValueError):
        return None


def _check_outputs(paths, overwrite):
    for p in paths:
        folder = os.path.dirname(os.path.abspath(p))
        if not os.path.isdir(folder):
            raise ValueError(f"{p}: cannot write: no folder {folder}")
        if not overwrite and os.path.lexists(p):
            raise ValueError(f"{p}: already exists (overwrite=True replaces it)")
        _check_output_format(p)


def _render_shard(run, mesh, handles, out, dtype, options, frames):
    """One task of render_animation: the frames `frames` on this worker's job of `run`, built from the files if
    this is the worker's first task of the run. Stops before the next frame if the run is stopped (_stop)."""
    if not _begin(run):
        return {"stopped": True}
    try:
        return _render_frames(run, mesh, handles, out, dtype, options, frames)
    finally:
        _end(run)


def _render_frames(run, mesh, handles, out, dtype, options, frames):
    built = False
    with _sessions_lock:
        entry = _sessions.get(run)
        if entry is None:
            # One job per worker process, shared by its threads (threads_per_worker > 1): a job deforms and
            # encodes one frame at a time (its buffers are its own), so its frames take turns under its lock;
            # each frame uses the worker's threads inside the library.
            entry = _sessions[run] = (_job(mesh, handles, out, dtype, options), threading.Lock())
            built = True
    job, job_lock = entry
    seconds_deform = seconds_write = 0.0
    written, nbytes = [], 0
    cpu = time.process_time()
    for frame in frames:
        if run in _stopped:
            break
        t0 = time.perf_counter()
        with job_lock:
            data, deform, _ = job.encode_frame(frame)
        t1 = time.perf_counter()
        path = job.outputs[frame]
        files.write_atomically(path, data, run)
        nbytes += len(data)
        _wrote(run, path)
        seconds_deform += deform
        seconds_write += time.perf_counter() - t1 + (t1 - t0 - deform)
        written.append((frame, path))
    return {
        "written": written,
        "bytes": nbytes,
        "deform": seconds_deform,
        "write": seconds_write,
        "built": built,
        "cpu": time.process_time() - cpu,
    }


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
    the Dask `client`'s workers, into the program's file names for `out` (OUT_0000.EXT, ...; any format the
    program writes), byte for byte the program's files. `options`: the program's (the module docstring); `dtype`
    is the session's precision (the program's --precision). `frames_per_task`: the shard size (default: about
    four tasks per worker thread). Returns a Summary. ValueError for bad input or outputs that exist, before
    anything is sent to the cluster. Interrupted (KeyboardInterrupt) or failed: the tasks are cancelled, the
    frames written removed, and the exception raised again."""
    start = time.perf_counter()
    # Read and checked here, so that bad input fails before anything is sent (each worker reads them again).
    m = files.read_mesh(mesh, dtype)  # in the session's precision, as the program's --precision
    anim = files.read_handles(handles, m.vertices, dtype)
    paths = _output_paths(out, len(anim.frames), anim.animated)
    _check_outputs(paths, overwrite)
    dropped = m.attributes(out, options.get("normals", "input"))["dropped"]
    if dropped and options.get("strict_attributes"):
        raise ValueError(f"{mesh}: the output {out} cannot keep: {'; '.join(dropped)} (strict_attributes)")
    del m
    run = uuid.uuid4().hex
    if threads is not None:
        options["threads"] = threads
    workers = max(1, sum(client.nthreads().values()))
    n = len(anim.frames)
    per_task = frames_per_task or max(1, -(-n // (4 * workers)))
    setup = time.perf_counter() - start
    futures = []
    summary = Summary(seconds_setup=setup)
    try:  # submitted in the try: an interrupt while submitting cancels what was submitted
        for first in range(0, n, per_task):
            futures.append(
                client.submit(
                    _render_shard,
                    run,
                    mesh,
                    handles,
                    out,
                    dtype,
                    options,
                    list(range(first, min(n, first + per_task))),
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
    if dropped:
        summary.dropped[mesh] = dropped
    summary.seconds = time.perf_counter() - start
    return summary


def _deform_one(run, mesh, handles, out, paths, options, dtype):
    """One task of deform_meshes: a mesh and its handles file to its outputs `paths` (computed on the client from
    the handles file's frames). Bad input -> ("failed", message); any other exception propagates (Dask retries the
    task), after removing what this attempt wrote. Stops before the next frame if the run is stopped (_stop)."""
    if not _begin(run):
        return {"stopped": True}
    try:
        return _deform_frames(run, mesh, handles, out, paths, options, dtype)
    finally:
        _end(run)


def _deform_frames(run, mesh, handles, out, paths, options, dtype):
    t0 = time.perf_counter()
    try:
        job = _job(mesh, handles, out, dtype, options)
        if job.outputs != paths:
            raise ValueError(
                f"{handles}: changed during the run ({len(paths)} outputs counted, now {len(job.outputs)})"
            )
    except ValueError as e:
        return {"failed": str(e)}
    seconds_deform, seconds_write, nbytes, written = time.perf_counter() - t0, 0.0, 0, []
    try:
        for i, path in enumerate(paths):
            if run in _stopped:
                break
            t1 = time.perf_counter()
            data, deform, _ = job.encode_frame(i)
            t2 = time.perf_counter()
            files.write_atomically(path, data, run)
            nbytes += len(data)
            _wrote(run, path)
            seconds_deform += deform
            seconds_write += time.perf_counter() - t2 + (t2 - t1 - deform)
            written.append(path)
    except BaseException as e:
        # All or nothing per mesh as well: a retry writes them all again.
        for p in written:
            try:
                os.unlink(p)
            except OSError:
                pass
        if isinstance(e, ValueError):  # a frame the program refuses (bad input): no retry would change it
            return {"failed": str(e)}
        raise
    return {
        "written": written,
        "bytes": nbytes,
        "deform": seconds_deform,
        "write": seconds_write,
        "frames": len(paths),
        "dropped": job.summary["dropped"],
    }


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
    """Deforms every mesh NAME.EXT of `in_dir` in a format the program reads (.obj, .off, .ply, their .gz) that
    has a handles file NAME.json beside it, one task per mesh over the Dask `client`'s workers, into `out_dir`
    (NAME_0000.EXT per frame of the handles file, or NAME.EXT, named as the program names frames; EXT is
    `output_format`, any the program writes), byte for byte the program's files. `options`: the program's (the
    module docstring). Returns a Summary whose `failed` maps each mesh that could not be done to the reason; the
    others are written. ValueError, before any work, when two meshes would write one file or (unless
    overwrite=True) an output exists. Interrupted (KeyboardInterrupt): the tasks are cancelled, every file the run
    wrote removed, and the exception raised again."""
    start = time.perf_counter()
    if not isinstance(output_format, str) or not output_format.startswith("."):
        raise ValueError(f"output_format {output_format!r}: a file extension such as '.ply'")
    _check_output_format("output" + output_format)
    if not os.path.isdir(out_dir):
        raise ValueError(f"{out_dir}: no such folder")
    jobs = []
    for entry in sorted(os.listdir(in_dir)):
        base = entry[:-3] if entry.lower().endswith(".gz") else entry
        # NAME.compressed.ply (a splat format) is NAME with its handles NAME.json, as the program names it.
        compressed = base.lower().endswith(".compressed.ply")
        name = base[: -len(".compressed.ply")] if compressed else os.path.splitext(base)[0]
        try:
            _mesh_format(entry)  # the program's readers, by the name's extension
        except ValueError:
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
                os.path.join(out_dir, name + output_format),
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
        if r["dropped"]:
            summary.dropped[mesh] = r["dropped"]
    summary.seconds = time.perf_counter() - start
    return summary
