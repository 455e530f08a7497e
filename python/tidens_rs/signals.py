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

import ctypes
import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

# Exit status of a process ended by SIGTERM (128 + 15), as shells report it.
EXIT_TERMINATED = 128 + signal.SIGTERM
# prctl's option for the signal sent at the parent's death (linux/prctl.h).
_PR_SET_PDEATHSIG = 1


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


def stop_with_parent(parent_pid: int) -> None:
    """On Linux, has the kernel send this process SIGTERM when its parent
    (process ``parent_pid``) dies, and sends it at once if the parent is gone
    already; elsewhere does nothing. A sweep's worker processes call it
    inside :func:`sigterm_stops`, so that a sweep killed outright (SIGKILL,
    or SIGTERM to a script that does not catch it) leaves no worker running
    on into its folders: each stops its run as on Ctrl-C."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) != 0:
            return
    except (OSError, AttributeError):
        return
    if os.getppid() != parent_pid:
        os.kill(os.getpid(), signal.SIGTERM)
