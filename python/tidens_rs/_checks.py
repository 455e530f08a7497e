"""Type and finiteness checks of the Python API's arguments.

The ranges live in the core (one source, :func:`tidens_rs._core.check_parameters`);
these helpers make sure that what reaches it is the kind of value it expects,
and name the argument as the user wrote it when it is not: a string, None, a
list, a complex number or a bool where a number belongs is a TypeError, NaN or
infinity a ValueError.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np


def real(name: str, value: Any, unit: str = "") -> float:
    """``value`` as a finite float; TypeError or ValueError naming ``name``."""
    # bool is an int in Python, but True is a mistake, not 1.
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} = {value!r}: must be a real number{unit and ' [' + unit + ']'}, not {type(value).__name__}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} = {value!r}: must be finite")
    return x


def optional_real(name: str, value: Any, unit: str = "") -> float | None:
    """None, or ``value`` as a finite float."""
    return None if value is None else real(name, value, unit)


def integer(name: str, value: Any) -> int:
    """``value`` as an int (an integral float such as 2.0 is not one)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} = {value!r}: must be an integer, not {type(value).__name__}")
    if abs(int(value)) >= 2**62:
        # Beyond the core's 64-bit integers; every range it allows is far smaller.
        raise ValueError(f"{name} = {value!r}: far out of range")
    return int(value)


def flag(name: str, value: Any) -> bool:
    """``value`` as a bool (True or False only: 0, 1 and "yes" are not)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} = {value!r}: must be True or False, not {type(value).__name__}")
    return bool(value)


def choice(name: str, value: Any, choices: Sequence[str]) -> str:
    """``value`` if it is one of ``choices``; the error lists them."""
    if not isinstance(value, str):
        raise TypeError(f"{name} = {value!r}: must be a string, one of {', '.join(choices)}")
    if value not in choices:
        raise ValueError(f"{name} = {value!r}: must be one of {', '.join(choices)}")
    return value


def reals(name: str, values: Any, unit: str = "") -> list[float]:
    """A sequence of finite floats (a numpy array is one; a string is not)."""
    if isinstance(values, np.ndarray):
        values = values.tolist()
    if isinstance(values, (str, bytes)) or not isinstance(values, Sequence):
        raise TypeError(f"{name} = {values!r}: must be a list of numbers, not {type(values).__name__}")
    return [real(f"{name}[{k}]", v, unit) for k, v in enumerate(values)]


def in_open_range(name: str, value: float, lo: float, hi: float, what: str) -> float:
    """``value`` if lo < value < hi; else a ValueError quoting ``what``
    (the range as the user should read it, e.g. "(rho0 = 0.5236, 1)")."""
    if not lo < value < hi:
        raise ValueError(f"{name} = {value!r}: must be in {what}")
    return value
