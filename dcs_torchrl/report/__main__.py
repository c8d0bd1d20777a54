"""Command line: ``python -m dcs_torchrl.report <results dir> [--out DIR] [--experiment NAME]``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from dcs_torchrl.report.build import REPORTED, build_report


def main(argv: list[str] | None = None) -> int:
    """Builds the report; prints where it went. Returns the exit code (0, or 2 on a bad path)."""
    parser = argparse.ArgumentParser(
        prog="python -m dcs_torchrl.report",
        description="Tables and figures of the Distracting Control Suite paper from a directory of results.json files.",
    )
    parser.add_argument("results_dir", type=Path, help="directory searched recursively for results.json")
    parser.add_argument("--out", type=Path, default=None, help="output directory (default: <results_dir>/report)")
    parser.add_argument("--experiment", choices=REPORTED, default=None, help="report only this experiment")
    args = parser.parse_args(argv)
    if not args.results_dir.is_dir():
        parser.error(f"results directory {str(args.results_dir)!r} does not exist")
    out = args.out if args.out is not None else args.results_dir / "report"
    report = build_report(args.results_dir, out, args.experiment, log=sys.stderr)
    loaded = report.loaded
    print(f"{len(loaded.runs)} runs, {loaded.n_left_out} left out, {len(loaded.skipped)} skipped; "
          f"report: {out / 'report.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
