"""Validation helpers shared by the tables of a case (lumped model, [reduction], ...).

Each appends one line per fault to ``out``, naming the key, the value and what is allowed,
so that every fault of a file is reported at once, before any work starts.
"""

from __future__ import annotations

import difflib
from typing import Any

import numpy as np

from microslip.fourier import SAMPLES_PER_ORDER, least_samples


def unknown_keys(prefix: str, table: Any, allowed: set[str], out: list[str]) -> None:
    """A fault for a value that is not a table, and one per key not in ``allowed``."""
    if not isinstance(table, dict):
        out.append(f"{prefix.rstrip('.') or 'case'}: expected a table, got {table!r}")
        return
    for k in sorted(set(table) - allowed, key=str):
        near = difflib.get_close_matches(str(k), sorted(allowed), n=1)
        hint = f"did you mean {near[0]!r}? " if near else ""
        out.append(f"{prefix}{k}: unknown key; {hint}allowed: {sorted(allowed)}")


def is_int(v: Any) -> bool:
    """An integer (TOML booleans are not)."""
    return isinstance(v, int) and not isinstance(v, bool)


def is_number(v: Any) -> bool:
    """A finite int or float (TOML booleans are not numbers)."""
    return isinstance(v, int | float) and not isinstance(v, bool) and bool(np.isfinite(v))


def number(key: str, value: Any, out: list[str], *, positive: bool = False,
           nonneg: bool = False, integer: bool = False) -> bool:
    """True if ``value`` is a finite number (an integer if asked) within the sign bound;
    otherwise one fault naming ``key``."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if ok and integer:
        ok = isinstance(value, int)
    if not ok:
        kind = "an integer" if integer else "a number"
        out.append(f"{key} = {value!r}: expected {kind}")
        return False
    if not np.isfinite(value):
        out.append(f"{key} = {value!r}: must be finite")
        return False
    if positive and value <= 0:
        out.append(f"{key} = {value!r}: must be > 0")
        return False
    if nonneg and value < 0:
        out.append(f"{key} = {value!r}: must be >= 0")
        return False
    return True


# ------------------------------------------------------------ time samples per period
def samples_rule(key: str, value: Any, top: int, out: list[str]) -> bool:
    """True if ``value`` samples per period suit highest harmonic ``top``: a power of two
    >= 16 (top + 1), the rule of ``harmonics.default_samples``. 16 per period of the top
    harmonic resolves the stick-slip transitions of the return map; powers of two nest
    (every sample of N is one of 2 N), so results converge as samples double. Fewer, or
    another count, still solve, to a wrong peak with no sign of it."""
    if not number(key, value, out, positive=True, integer=True):
        return False
    need = SAMPLES_PER_ORDER * (top + 1)
    power = value & (value - 1) == 0
    if power and value >= need:
        return True
    why = [f"too few for order {top}"] if value < need else []
    why += [] if power else ["not a power of two"]
    least = least_samples(top)
    nearest = max(least, 1 << (value - 1).bit_length())
    hint = f"the smallest is {least}" + (f", the nearest above {value} is {nearest}"
                                         if nearest != least else "")
    out.append(f"{key} = {value}: {' and '.join(why)}; allowed: a power of two >= 16 (H + 1) "
               f"= {need} for the highest harmonic H = {top}; {hint}")
    return False
