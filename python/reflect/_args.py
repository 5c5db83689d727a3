"""Checks of keyword arguments, the one place each is turned into the type the core takes.

Every bad argument raises ``reflect.InputError`` (a ``ValueError``) naming the keyword (``spp=``): a negative or too large
integer, a float where an integer is needed (``3.0`` too, as ``range`` refuses it: no silent
truncation), a bool where a number is needed, NaN or ±inf, or a value of the wrong type.
"""

from __future__ import annotations

import math
import numbers
import operator
from typing import Any, Optional

import numpy as np

from ._errors import InputError

U32_MAX = 2**32 - 1
U64_MAX = 2**64 - 1


def _shown(v: Any) -> str:
    return f"{v!r} ({type(v).__name__})"


def integer(name: str, v: Any, lo: int = 0, hi: int = U64_MAX) -> int:
    """``v`` as an int in ``lo..=hi``: an ``int`` or NumPy integer, not a bool or a float."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (numbers.Integral, np.integer)):
        raise InputError(f"{name}= must be an integer, got {_shown(v)}")
    i = operator.index(v)
    if not lo <= i <= hi:
        raise InputError(f"{name}= must be an integer in {lo}..={hi}, got {i}")
    return i


def optional_integer(name: str, v: Any, lo: int = 0, hi: int = U64_MAX) -> Optional[int]:
    return None if v is None else integer(name, v, lo, hi)


def real(name: str, v: Any) -> float:
    """``v`` as a finite float: an int or float (NumPy's too), not a bool, NaN or ±inf."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (numbers.Real, np.integer, np.floating)):
        raise InputError(f"{name}= must be a number, got {_shown(v)}")
    x = float(v)
    if not math.isfinite(x):
        raise InputError(f"{name}= must be a finite number, got {x}")
    return x


def optional_real(name: str, v: Any) -> Optional[float]:
    return None if v is None else real(name, v)


def boolean(name: str, v: Any) -> bool:
    """``v`` as a bool: ``True``/``False`` (NumPy's too), not 0/1 or a string."""
    if not isinstance(v, (bool, np.bool_)):
        raise InputError(f"{name}= must be True or False, got {_shown(v)}")
    return bool(v)


def string(name: str, v: Any) -> str:
    if not isinstance(v, str):
        raise InputError(f"{name}= must be a string, got {_shown(v)}")
    return v


def optional_string(name: str, v: Any) -> Optional[str]:
    return None if v is None else string(name, v)
