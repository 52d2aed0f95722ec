"""One point's march to its periodic steady state (the kernels march dispatches to): the
synthesis of its motion, the cycle, the derivatives, the sub-sample corrections, the
projection onto the harmonics and the state counts."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..states import SAMPLE_OPEN, SAMPLE_SLIP, SAMPLE_STICK
from .cycle import (
    CORNER,
    PLAIN,
    corner_derivative,
    erased,
    periodic_cycle,
    periodic_derivative,
)
from .kinks import kink_corrections
from .steps import march_period


@njit(cache=True)
def march_serial(g, motion, law, dft, has_normal, want_jac, max_periods, rtol, corrections,
                 out):  # pragma: no cover
    """march, one point after the other (the arguments: as :func:`_point`'s)."""
    for p in range(g.shape[0]):
        _point(p, g, motion, law, dft, has_normal, want_jac, max_periods, rtol, corrections,
               out)


@njit(cache=True, parallel=True)
def march_parallel(g, motion, law, dft, has_normal, want_jac, max_periods, rtol, corrections,
                   out):  # pragma: no cover
    """march, the points shared among threads."""
    for i in prange(g.shape[0]):
        # prange's index is unsigned: an int64 point reuses the serial kernel's _point
        _point(np.int64(i), g, motion, law, dft, has_normal, want_jac, max_periods, rtol,
               corrections, out)


@njit(inline="always")  # one compiled level less: each re-optimises all it links (~2 s)
def _point(p, g, motion, law, dft, has_normal, want_jac, max_periods, rtol, corrections,
           out):  # pragma: no cover
    """march for point p. motion: (u, v), written here (the synthesis of g); law: (kt, kn,
    mu, n0); dft: (E, A, corder, ckind); out: (T_out, N_out, state_out, F_out, J_out, D_out,
    periods_out, counts_out): as the package's :func:`march` names them."""
    u, _ = motion
    E, A, corder, ckind = dft
    T_out, N_out, state_out, F_out, J_out, D_out, periods_out, counts_out = out
    kn, mu = law[1], law[2]
    d, ns = u.shape[1], u.shape[2]
    m = J_out.shape[3] + 1
    yes, no = np.bool_(True), np.bool_(False)
    _synthesis(p, g, E, has_normal, motion)
    G = np.empty((ns, d * m)) if want_jac else np.empty((1, 1))  # every row written
    dT = np.zeros((d, m))
    T = np.empty(d)
    state = (T, np.empty(d), dT, G)
    samples = (T_out, N_out, state_out)
    periods, how, ca, cb = periodic_cycle(p, motion, law, E, has_normal, no, max_periods, rtol,
                                          state, samples)
    if want_jac:
        e = -1
        for k in range(ns):
            if state_out[p, k] == SAMPLE_OPEN or (d == 1 and state_out[p, k] == SAMPLE_SLIP):
                e = k
                break
        if e >= 0:
            erased(p, e, kn, mu, E, has_normal, T_out, N_out, state_out, T, dT)
            for j in range(d):
                for col in range(m):
                    G[e, j * m + col] = dT[j, col]
            march_period(p, e + 1, ns - 1, state_out[p, e] == SAMPLE_OPEN, motion, law, E,
                         has_normal, yes, yes, state, samples, np.int64(-1),
                         state_out[p, e] == SAMPLE_SLIP)
        elif how == CORNER:
            corner_derivative(p, ca, cb, motion, law, E, has_normal, state, samples)
        elif periods <= 2 or not periodic_derivative(p, motion, law, E, has_normal,
                                                     how == PLAIN, state, samples):
            # the march again with derivatives from the start convention: short, or a
            # stuck cycle whose start state is the march's choice (Firrone & Zucca eqs. 26-28)
            periodic_cycle(p, motion, law, E, has_normal, yes, periods, 0.0, state, samples)
    periods_out[p] = periods
    _project(p, kn, E, A, has_normal, want_jac, G, out)
    if corrections:
        kink_corrections(p, g, law, motion, (E, corder, ckind), has_normal, want_jac,
                         (T_out, N_out, state_out, G, F_out, J_out, D_out))
    _count(p, state_out, T_out, counts_out)


@njit(cache=True)
def _synthesis(p, g, E, has_normal, motion):  # pragma: no cover
    """Time samples of one point's relative displacements from coefficients, into motion
    (u, v)."""
    u, v = motion
    d, ns = u.shape[1], u.shape[2]
    nc = E.shape[1]
    for k in range(ns):
        for j in range(d):
            acc = 0.0
            for c in range(nc):
                acc += g[p, j, c] * E[k, c]
            u[p, j, k] = acc
        acc = 0.0
        if has_normal:
            for c in range(nc):
                acc += g[p, d, c] * E[k, c]
        v[p, k] = acc


@njit(cache=True)
def _count(p, state_out, T_out, counts_out):  # pragma: no cover
    """Open and slipping samples, and stick arcs of 0 to 2 samples between slips
    (0: the force reverses between two slipping samples)."""
    d, ns = T_out.shape[1], T_out.shape[2]
    n_open = n_slip = short = 0
    for k in range(ns):
        s = state_out[p, k]
        prev = state_out[p, (k - 1) % ns]
        if s == SAMPLE_OPEN:
            n_open += 1
        elif s == SAMPLE_SLIP:
            n_slip += 1
            if prev == SAMPLE_SLIP:
                dot = 0.0
                for j in range(d):
                    dot += T_out[p, j, k] * T_out[p, j, (k - 1) % ns]
                if dot < 0.0:
                    short += 1
        elif prev == SAMPLE_SLIP:  # a stick arc starts: 1 or 2 samples long?
            nxt = state_out[p, (k + 1) % ns]
            after = state_out[p, (k + 2) % ns]
            if nxt == SAMPLE_SLIP or (nxt == SAMPLE_STICK and after == SAMPLE_SLIP):
                short += 1
    counts_out[p, 0] = n_open
    counts_out[p, 1] = n_slip
    counts_out[p, 2] = short




@njit(cache=True)
def _project(p, kn, E, A, has_normal, want_jac, G, out):  # pragma: no cover
    """Trapezoid projection of the final period's samples and derivatives (G) into the
    force coefficients and derivatives of ``out`` (as :func:`_point`'s)."""
    T_out, N_out, _, F_out, J_out, D_out, _, _ = out
    d, ns = T_out.shape[1], T_out.shape[2]
    nc = E.shape[1]
    m = J_out.shape[3] + 1
    vcol = d * nc
    for c in range(nc):
        for j in range(d):
            acc = 0.0
            for k in range(ns):
                acc += A[c, k] * T_out[p, j, k]
            F_out[p, j, c] = acc
        acc = 0.0
        for k in range(ns):
            acc += A[c, k] * N_out[p, k]
        F_out[p, d, c] = acc
    if not want_jac:
        return
    J = np.dot(A, G)  # (nc, d m)
    for j in range(d):
        for c in range(nc):
            for col in range(m - 1):
                J_out[p, j, c, col] = J[c, j * m + col]
            D_out[p, j, c] = J[c, j * m + m - 1]
    if has_normal:
        # normal force: dN_k = [N_k > 0] (kn E_k on v, 1 on n0)
        for c in range(nc):
            for col in range(m - 1):
                J_out[p, d, c, col] = 0.0
            D_out[p, d, c] = 0.0
            for k in range(ns):
                if N_out[p, k] > 0.0:
                    a = A[c, k]
                    for c2 in range(nc):
                        J_out[p, d, c, vcol + c2] += a * kn[p] * E[k, c2]
                    D_out[p, d, c] += a
