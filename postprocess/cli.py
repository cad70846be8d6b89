"""Shared command-line plumbing: error exits, run loading, common options."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .reader import Run, read_run


class UsageError(ValueError):
    """A bad argument found after parsing (reported as 'error: ...', exit 1)."""


def run_main(body, args) -> int:
    """Call body(args); turn expected errors into one stderr line and exit 1."""
    try:
        body(args)
    except (FileNotFoundError, ValueError, OSError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"error: {msg}", file=sys.stderr)
        return 1
    return 0


def load_run(path, min_steps: int = 1) -> Run:
    """read_run plus the one-line notice for unfinished runs (on stderr)."""
    run = read_run(path)
    line = run.status_line()
    if line:
        print(line, file=sys.stderr)
    if run.nt < min_steps:
        raise ValueError(f"{path}: {run.nt} complete output steps, "
                         f"need at least {min_steps}")
    return run


def parser(description: str, prog: str) -> argparse.ArgumentParser:
    """The parser of a script, its usage naming the console script (nuno-<prog>)."""
    return argparse.ArgumentParser(prog=script_name(prog), description=description)


def script_name(prog: str) -> str:
    """The console script of module prog (pyproject.toml): nuno-report-figures for report_figures."""
    return "nuno-" + prog.replace("_", "-")


def add_output(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("-o", "--output", default=None,
                   help=f"output file (default: <input stem>_{what}.png; "
                        "the format follows the extension)")
    p.add_argument("--dpi", type=int, default=120, help="resolution (default 120)")


def default_output(input_path, what: str, ext: str = ".png") -> str:
    return f"{Path(input_path).stem}_{what}{ext}"
