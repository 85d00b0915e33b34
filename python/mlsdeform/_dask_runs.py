"""mlsdeform.dask's bookkeeping: what a run wrote (Summary), and on each worker process the run's job, its running
tasks and the files they wrote, so that a run the client abandons stops and removes them (dask.py)."""
import asyncio
import os
import threading
import time
from dataclasses import dataclass, field

from . import files

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
    `seconds_setup`: of `seconds`, the client's part before the first task (render_animation: reading and
    checking the mesh and the handles file); `cpu_seconds`: the CPU time of the worker processes while they
    ran the frames (render_animation; with the worker's other threads, if any); `sessions_built`: sessions built
    on the workers (one per worker for render_animation, one per mesh for deform_meshes, more when a worker died
    and its replacement built its own); `temporaries_removed`: files of attempts that died; `dropped`: {input:
    the attributes its outputs could not keep}, as the program names them on stderr."""

    written: list = field(default_factory=list)
    failed: dict = field(default_factory=dict)
    dropped: dict = field(default_factory=dict)
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


def _job(mesh, handles, out, dtype, options):
    """The program's deform of `mesh` with `handles` into `out`, on this worker (outputs are checked on the
    client: the job may replace them, as an attempt that ran before wrote them)."""
    opts = dict(options)
    opts["threads"] = _threads(opts.pop("threads", None))
    return files.DeformJob(mesh, handles, out, dtype=dtype, overwrite=True, **opts)


def _forget(run):
    with _sessions_lock:
        _sessions.pop(run, None)
        _active.pop(run, None)
        _written.pop(run, None)
