# SPDX-License-Identifier: BSD-2-Clause
"""Post-processing of nuno runs: one reader and small plotting scripts.

Installed (``pip install .``), the package is imported as ``nuno``: read a
run with :func:`nuno.reader.read_run`; each script is a console command
``nuno-<name>`` and a module ``python3 -m nuno.<name>`` (snapshots,
timeseries, animate, compare, convergence, workprecision, sweep, ...). In a
checkout without installing, the same modules run from the repository root
as ``python3 -m postprocess.<name>`` (the folder's name; the modules import
each other relatively, so either name works). See postprocess/README.md.
"""

from .reader import Run, read_run

__all__ = ["Run", "read_run"]
