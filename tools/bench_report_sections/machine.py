"""The run: the machine, the build, the load and the command."""


from .common import table


def write(md, inputs):
    """Appends the section to md (a list of markdown lines)."""
    t2, run, ctx = inputs.t2, inputs.run, inputs.ctx
    md.append("## Machine and run\n")
    lib_isa = (t2.context or {}).get("library_isa", "?")
    md.append(
        table(
            ["", ""],
            [
                ["date", run.get("date", ctx.get("date", "?"))],
                [
                    "CPU",
                    f"{ctx.get('cpu_model', '?')}, {ctx.get('num_cpus', '?')} cores as seen by the VM, "
                    f"{ctx.get('mhz_per_cpu', '?')} MHz nominal; caches L1d 32 KiB, L2 1 MiB per core, L3 32 MiB",
                ],
                ["ISA (cpuid)", ctx.get("cpu_isa", "?")],
                ["ISA used by the library", lib_isa + "; the batched fits are also run forced to each ISA"],
                ["threads", f"{ctx.get('hardware_threads', '?')} hardware threads; each table says what it used"],
                [
                    "compiler",
                    "g++ " + ctx.get("compiler", "?") + ", CMake Release, library built for generic x86-64 "
                    "(per-ISA kernels dispatched at run time)",
                ],
                [
                    "load average",
                    f"before the run: {run.get('load_before', '?')}; after: {run.get('load_after', '?')} "
                    "(2 cores shared with other engineers' builds: a load above ~0.5 inflates wall-clock times)",
                ],
                ["command", f"`{run.get('command', 'tools/bench_report.sh')}`"],
                ["library source", "commit " + run.get("commit", "?")],
                ["wall time of the suite", run.get("suite_seconds", "?") + " s"],
            ],
        )
    )
    md.append(
        "\nGoogle Benchmark from Debian 12 prints `***WARNING*** Library was built as DEBUG. Timings may be "
        "affected.` (and records `library_build_type: debug`): that is the packaged libbenchmark's own "
        "build type, which only affects its bookkeeping between timed loops, not the code measured here, "
        "which is built Release. Harmless.\n"
    )
    md.append(
        "**Timing.** Single-threaded benchmarks report the benchmark thread's CPU time (Google Benchmark's "
        "default), which another process taking turns on the same core does not inflate much; multi-threaded "
        "ones (names with `threads:N` or `simd all`, and every `kernel/deform`) report wall-clock time, since "
        "TBB's workers do the work. Wall-clock figures, and hence every ratio against a multi-threaded run, "
        "are only as good as the machine is quiet: see the load average above.\n"
    )
    md.append(
        "Every benchmark checks its results before timing and skips with an error on a mismatch: rotation "
        "fits against a long-double SVD reference (`bench/reference.hpp`, tolerances derived there), "
        "deformations against the tests' direct MLS evaluation in double (`tests/support/mls_reference.hpp`, "
        "`deform_tolerance`). "
        "Skipped benchmarks are listed at the end with their messages.\n"
    )
