"""The ``--save`` and ``--report-only`` options the benches share: rows
written as JSON as they come, and their tables printed again without a
run."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

Rows = list[dict[str, Any]]


def add_options(ap: argparse.ArgumentParser) -> None:
    """Adds ``--save JSON`` and ``--report-only JSON`` to ``ap``."""
    ap.add_argument("--save", type=Path, help="the rows as JSON, written as they come")
    ap.add_argument("--report-only", type=Path, metavar="JSON", help="no runs: the tables of rows saved with --save")


def report_only(args: argparse.Namespace, report: Callable[[Rows], None]) -> bool:
    """With ``--report-only``: prints ``report`` of the saved rows and
    returns True (nothing to run)."""
    if args.report_only is None:
        return False
    report(json.loads(args.report_only.read_text()))
    return True


def save(args: argparse.Namespace, rows: Rows) -> None:
    """Writes ``rows`` to the ``--save`` file, if one was given (values JSON
    cannot hold as null)."""
    if args.save is not None:
        args.save.write_text(json.dumps(rows, indent=1, default=lambda _: None))
