"""Post-processing of nuno runs: one reader and small plotting scripts.

Read a run with :func:`postprocess.reader.read_run`; each script is a module
runnable as ``python3 -m postprocess.<name>`` (snapshots, timeseries, animate,
compare, convergence, workprecision). See postprocess/README.md.
"""

from postprocess.reader import Run, read_run

__all__ = ["Run", "read_run"]
