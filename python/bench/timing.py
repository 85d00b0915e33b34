"""What the Python benchmarks share: the line naming the build and the machine, and the timing loops (best
of several runs: the least disturbed by other load, the way the C++ benchmarks report them)."""
import os
import platform
import time

import mlsdeform


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def banner():
    """The package's version, its instruction set, the CPU and its cores: the first line of every report."""
    return f"mlsdeform {mlsdeform.__version__}, {mlsdeform.active_isa()}, {cpu_name()}, {os.cpu_count()} cores"


def best_of(f, repeat=7):
    """Seconds of the fastest of `repeat` calls of f(), timed from Python."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def cpp_seconds_per_frame(d, reps, repeat, warmup=0, **handles):
    """Seconds per frame of the session d's C++ deform loop (timed inside C++, no Python in the loop): the
    fastest of `repeat` runs of `reps` frames, after `warmup` frames. handles: deform's keyword arguments."""
    if warmup:
        d._time_cpp_deform(reps=warmup, **handles)
    return min(d._time_cpp_deform(reps=reps, **handles) for _ in range(repeat))
