"""Work-precision plot: run time against error (log-log, fitted slope).

    nuno-workprecision study.csv --group-column ts_type -o wp.png
"""

from __future__ import annotations

from . import cli, loglog


def main(argv=None) -> int:
    p = loglog.make_parser("workprecision", __doc__.splitlines()[0], "error", "run_time")
    return cli.run_main(loglog.run, p.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
