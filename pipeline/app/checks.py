"""Validation helpers shared by the tables of a case (lumped model, [reduction], ...).

Each appends one line per fault to ``out``, naming the key, the value and what is allowed,
so that every fault of a file is reported at once, before any work starts.
"""

from __future__ import annotations

import os
from typing import Any, NamedTuple

import numpy as np


def unknown_keys(prefix: str, table: Any, allowed: set[str], out: list[str]) -> None:
    """A fault for a value that is not a table, and one per key not in ``allowed``."""
    if not isinstance(table, dict):
        out.append(f"{prefix.rstrip('.') or 'case'}: expected a table, got {table!r}")
        return
    for k in sorted(set(table) - allowed):
        out.append(f"{prefix}{k}: unknown key; allowed: {sorted(allowed)}")


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
def least_samples(top: int) -> int:
    """The fewest time samples per period a case may give for highest harmonic ``top``:
    the smallest power of two >= 16 (top + 1)."""
    return 1 << (16 * (top + 1) - 1).bit_length()


def samples_rule(key: str, value: Any, top: int, out: list[str]) -> bool:
    """True if ``value`` samples per period suit highest harmonic ``top``: a power of two
    >= 16 (top + 1), the rule of ``harmonics.default_samples``. 16 per period of the top
    harmonic resolves the stick-slip transitions of the return map; powers of two nest
    (every sample of N is one of 2 N), so results converge as samples double. Fewer, or
    another count, still solve, to a wrong peak with no sign of it."""
    if not number(key, value, out, positive=True, integer=True):
        return False
    need = 16 * (top + 1)
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


# ------------------------------------------------------------ memory of a harmonic balance
class ContactShape(NamedTuple):
    """One contact of a harmonic balance, as far as its memory goes."""

    points: int  # contact points P
    components: int  # c: tangential directions, plus the normal one for laws B and D
    dim: int  # d: tangential directions
    dofs: int  # the DOFs one point touches


REAL = 8  # bytes of a float64
COMPLEX = 16
#: Dense (n x n) real copies a continuation step holds besides the cache: the Jacobian of the
#: current point, of the best and of the latest line-search trial, the bordered matrix, its LU
#: factors (kept for the tangent) and a scaled temporary (solve.continuation._correct). With
#: 7 the estimate came within -5 % / +17 % of the peak RSS of FRFs measured at 1,500 and
#: 4,500 unknowns (cache-bound) and -3 % at 601 unknowns and 8,192 samples (kernel-bound).
WORKING_COPIES = 7
#: Evaluations per converged point (Newton iterations and step halvings, each at a new
#: parameter value on an arclength branch, so each a new cache entry) and the points of a
#: typical curve: the shipped FRFs take 70 to 230 points at 3 to 11 evaluations each
#: (227 to 2,546 evaluations a curve). Large entries fill the cache to its limit anyway.
EVALUATIONS_PER_POINT = 5
TYPICAL_POINTS = 250


def balance_bytes(contact_dofs: int, linear_dofs: int, orders: int, coeffs: int, samples: int,
                  contacts: list[ContactShape], points: int, cache_limit: int) -> int:
    """Peak memory of a harmonic balance in bytes, from its sizes alone (nothing built).

    n = contact_dofs x coeffs real unknowns. Dense: the cache (``solve.hbm._Cache``) keeps
    per evaluated point the real condensed matrix and its parameter derivative (2 n^2 reals)
    and their complex per-order blocks, as many entries as fit in ``cache_limit`` (at least
    one) or as a curve of ``points`` (at most TYPICAL_POINTS) evaluates, plus the entry
    being made; a step holds WORKING_COPIES more. Linear part: K, M, C,
    M_part, D and dD per order (complex, ``linear_dofs`` square). Contact kernel: the
    synthesis and analysis matrices (samples x coeffs each), per point its Jacobian block
    (c coeffs)^2, the product B^T J B (dofs coeffs)^2 and the map B between them, the time
    histories, and per thread the time derivative matrix (samples x d c coeffs)."""
    n = contact_dofs * coeffs
    dense = REAL * n * n
    entry = 2 * dense + 2 * COMPLEX * orders * contact_dofs**2
    evaluations = min(points, TYPICAL_POINTS) * EVALUATIONS_PER_POINT
    held = max(1, min(cache_limit // max(entry, 1), evaluations))
    total = (held + 1) * entry + WORKING_COPIES * dense
    total += 6 * COMPLEX * orders * linear_dofs**2
    total += 2 * REAL * samples * coeffs
    threads = os.cpu_count() or 1
    for c in contacts:
        m, k = c.components * coeffs, c.dofs * coeffs
        total += REAL * c.points * (m * m + k * k + m * k + 4 * c.components * samples)
        total += REAL * min(c.points, threads) * samples * c.dim * (m + 1)
    return total


def available_memory() -> int | None:
    """Bytes the machine can still give a process: MemAvailable of /proc/meminfo (Linux),
    else the free physical pages, else all physical memory; None if none is known."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    for pages in ("SC_AVPHYS_PAGES", "SC_PHYS_PAGES"):
        try:
            return os.sysconf(pages) * os.sysconf("SC_PAGE_SIZE")
        except (AttributeError, ValueError, OSError):
            continue
    return None


def memory_text(nbytes: float) -> str:
    """A memory size as the check line prints it: '~6.4 GB', '~0.2 GB', '~12 MB', '<1 MB'."""
    if nbytes >= 0.1e9:
        return f"~{nbytes / 1e9:.1f} GB"
    return f"~{nbytes / 1e6:.0f} MB" if nbytes >= 1e6 else "<1 MB"
