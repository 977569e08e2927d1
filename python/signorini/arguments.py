"""Argument conversion for the facade: Python values into the exact types and shapes the core
takes, or a TypeError / ValueError naming who (the body or call) and what (the argument). Ranges
are the core's to check; nothing here is physics."""
from __future__ import annotations

import numpy as np

from . import _core

ALL_BITS = 0xFFFFFFFF  # collision filter bits: every category
INT_MAX = 2**31 - 1  # the core's counts are C ints


def readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def as_vector(x, n: int, who: str, what: str) -> np.ndarray:
    """x as a float64 array of shape (n,), or a TypeError / ValueError naming who and what."""
    if isinstance(x, (str, bytes)):
        raise TypeError(f"{who}: {what} must be {n} numbers, got {x!r}")
    try:
        a = np.asarray(x, dtype=np.float64)
    except OverflowError:
        raise ValueError(f"{who}: {what} has a number too large for a double (at most about 1.8e308)") from None
    except (TypeError, ValueError):
        raise TypeError(f"{who}: {what} must be {n} numbers, got {x!r}") from None
    if a.shape != (n,):
        raise ValueError(f"{who}: {what} must have shape ({n},), got shape {a.shape}")
    return a


def as_rows(x, cols: int, who: str, what: str) -> np.ndarray:
    """x as a C-contiguous float64 array of shape (n, cols) (a single row may be given as (cols,))."""
    if isinstance(x, (str, bytes)):
        raise TypeError(f"{who}: {what} must be numbers of shape (n, {cols}), got {x!r}")
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{who}: {what} must be numbers of shape (n, {cols}), got {x!r}") from None
    if a.shape == (cols,):
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != cols:
        raise ValueError(f"{who}: {what} must have shape (n, {cols}), got shape {a.shape}")
    return np.ascontiguousarray(a)


def as_indices(x, who: str) -> np.ndarray:
    """x as an int64 array of shape (n,) (one integer gives one index); the core checks the range.
    Bools are not indices, not even among integers (NumPy reads [1, True] as [1, 1])."""
    if isinstance(x, (list, tuple)) and any(isinstance(k, (bool, np.bool_)) for k in x):
        raise TypeError(f"{who}: indices must be integers, got {x!r}")
    a = np.asarray(x)
    if a.ndim == 0:
        a = a.reshape(1)
    if a.dtype == np.bool_ or not (a.dtype.kind in "iu" or (a.size == 0 and a.dtype.kind == "f")):
        raise TypeError(f"{who}: indices must be integers, got {x!r}")
    if a.ndim != 1:
        raise ValueError(f"{who}: indices must have shape (n,), got shape {a.shape}")
    if a.dtype.kind == "u" and a.size and a.max() > np.iinfo(np.int64).max:
        raise _core.BodyIndexError(f"{who}: index {a.max()} is out of range")
    return np.ascontiguousarray(a, dtype=np.int64)


def as_index(x, who: str, what: str) -> int:
    """x as a body index (a Python or NumPy integer, not a bool); the core checks the range."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)):
        raise TypeError(f"{who}: {what} must be a body index (an integer), got {x!r}")
    if not -2**31 <= int(x) < 2**31:
        raise _core.BodyIndexError(f"{who}: {what} = {int(x)} is out of range")
    return int(x)


def as_bits(x, who: str, what: str) -> int:
    """x as a 32-bit unsigned integer (collision filter bits)."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)) or not 0 <= x <= ALL_BITS:
        raise TypeError(f"{who}: {what} must be an integer of 32 bits (0 to 0xFFFFFFFF), got {x!r}")
    return int(x)


def as_flag(x, who: str, what: str) -> bool:
    if not isinstance(x, (bool, np.bool_)):
        raise TypeError(f"{who}: {what} must be True or False, got {x!r}")
    return bool(x)


def as_name(x, who: str) -> str:
    if x is None:
        return ""
    if not isinstance(x, str):
        raise TypeError(f"{who}: name must be a string, got {x!r}")
    return x


def as_scalar(x, who: str, what: str):
    """x as a float (None stays None), or a TypeError / ValueError naming who and what."""
    if x is None:
        return None
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{who}: {what} must be a number, got {x!r}")
    try:
        return float(x)
    except OverflowError:
        raise ValueError(f"{who}: {what} is too large for a double: an integer of {len(str(abs(int(x))))} digits "
                         "(at most about 1.8e308)") from None


def as_number(x, who: str, what: str) -> float:
    """Like as_scalar, but None is a TypeError too."""
    if x is None:
        raise TypeError(f"{who}: {what} must be a number, got None")
    return as_scalar(x, who, what)


def as_count(x, who: str, what: str) -> int:
    """x as an int the core can hold, or a TypeError / ValueError naming who and what."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)):
        raise TypeError(f"{who}: {what} must be an integer, got {x!r}")
    if not -INT_MAX - 1 <= x <= INT_MAX:
        raise ValueError(f"{who}: {what} = {x} is too large: at most {INT_MAX}")
    return int(x)
