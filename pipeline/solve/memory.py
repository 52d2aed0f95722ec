"""The memory a harmonic balance will hold, from its sizes alone: what ``check`` and
``run --dry-run`` compare with the memory available before anything is built. It models
the caches of ``solve.hbm`` (their bound, ``hbm.CACHE_LIMIT``) and the working copies of
``solve.continuation``."""

from __future__ import annotations

import os
from typing import NamedTuple


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
#: factors (kept for the tangent) and a scaled temporary (solve.newton.corrector). With
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

    n = contact_dofs x coeffs real unknowns. The cache (``solve.hbm._Cache``) keeps per
    evaluated point the condensation's factors (D and dD per order, complex, ``linear_dofs``
    square), as many entries as fit in ``cache_limit`` (at least one) or as a curve of
    ``points`` (at most TYPICAL_POINTS) evaluates, plus the entry being made. Where
    ``hbm.structured_by_default`` says dense, each entry also holds the condensed blocks
    S and two real n x n matrices, and a step WORKING_COPIES more; where structured
    (``solve.jacobian``): the blocks S once, the preconditioner's
    single-precision inverses, the contact part's sparse matrix and the Krylov vectors
    (the sign's budget), nothing n x n but, at most ``jacobian.DENSE_FALLBACK`` unknowns,
    the dense fallback's matrix and its LU. Linear part: K, M, C, M_part per order
    (complex, ``linear_dofs`` square). Contact kernel: the synthesis and analysis matrices
    (samples x coeffs each), per point its Jacobian block (c coeffs)^2, the product
    B^T J B (dofs coeffs)^2 and the map B between them, the time histories, and per thread
    the time derivative matrix
    (samples x d c coeffs)."""
    from .hbm import structured_by_default
    from .jacobian import DENSE_FALLBACK, SIGN_KRYLOV

    n = contact_dofs * coeffs
    blocks = COMPLEX * orders * contact_dofs**2  # one complex N_dof^2 matrix per order
    entry = 2 * COMPLEX * orders * linear_dofs**2
    if not structured_by_default(contact_dofs, coeffs):
        dense = REAL * n * n
        entry += 2 * dense + blocks
        working = WORKING_COPIES * dense
    else:  # S, the order blocks being inverted, the inverses (complex64), Krylov vectors
        working = 2 * blocks + blocks // 2 + 2 * REAL * SIGN_KRYLOV * (n + 1)
        if n + 1 <= DENSE_FALLBACK:  # GMRES failed: the dense matrix, built, then its LU
            working += 2 * REAL * (n + 1) ** 2
        working += sum(12 * c.points * (c.dofs * coeffs) ** 2 for c in contacts)
    evaluations = min(points, TYPICAL_POINTS) * EVALUATIONS_PER_POINT
    held = max(1, min(cache_limit // max(entry, 1), evaluations))
    total = (held + 1) * entry + working
    total += 4 * COMPLEX * orders * linear_dofs**2
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
