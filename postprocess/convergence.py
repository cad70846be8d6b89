"""Convergence plot: error against a resolution parameter (log-log, fitted slope).

    python3 -m postprocess.convergence study.csv --x-column dt -o convergence.png
"""

from __future__ import annotations

from postprocess import cli, loglog


def main(argv=None) -> int:
    p = loglog.make_parser("convergence", __doc__.splitlines()[0], "parameter", "error")
    return cli.run_main(loglog.run, p.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
