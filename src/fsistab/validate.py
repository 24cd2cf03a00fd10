"""Checks of single input values: each returns the value as a float or raises
:class:`~fsistab.errors.InputError` with one line that names the quantity."""

from __future__ import annotations

import math

from fsistab.errors import InputError


def finite(name: str, value: float) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(value):
        raise InputError(f"{name} must be finite, got {value}")
    return value


def positive(name: str, value: float) -> float:
    value = finite(name, value)
    if value <= 0:
        raise InputError(f"{name} must be positive, got {value}")
    return value


def non_negative(name: str, value: float) -> float:
    value = finite(name, value)
    if value < 0:
        raise InputError(f"{name} must be non-negative, got {value}")
    return value
