"""The sections of docs/benchmarks.md, one module each, in the order of the page (tools/bench_report.py)."""
import matplotlib

# Files only, no display: before any section imports pyplot.
matplotlib.use("Agg")
