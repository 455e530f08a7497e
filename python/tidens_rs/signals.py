"""SIGTERM as a clean stop, like Ctrl-C.

A run stops within one Newton iteration of a signal: the solver runs
Python's signal handlers before each iteration, and a handler that raises
abandons the step, leaving the state at the last converged step. Ctrl-C
raises ``KeyboardInterrupt`` that way. Python's default for SIGTERM (what
``kill PID`` and batch schedulers send) ends the process at once, without
a summary; inside :func:`sigterm_stops` it raises :class:`Terminated`, a
``KeyboardInterrupt``, so the run ends as one stopped by Ctrl-C does
(status ``interrupted``, its summary written, resumable from its
checkpoint). The ``tidens`` commands and the sweeps' worker processes run
inside it; a script can too::

    with td.signals.sigterm_stops():
        case.run(0.95, out_dir="run")
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

# Exit status of a process ended by SIGTERM (128 + 15), as shells report it.
EXIT_TERMINATED = 128 + signal.SIGTERM


class Terminated(KeyboardInterrupt):
    """The process received SIGTERM (inside :func:`sigterm_stops`)."""


@contextmanager
def sigterm_stops() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` in the main
    thread (the first one only: later ones are ignored, so that the stop's
    clean-up, writing the summary and checkpoint, is not cut short). The
    handler before is restored at the end. Outside the main thread, where
    Python cannot install a handler, it does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received = False

    def handler(signum: int, frame: FrameType | None) -> None:
        nonlocal received
        if not received:
            received = True
            raise Terminated("terminated by SIGTERM")

    before = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)
