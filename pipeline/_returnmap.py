"""Compiled hot loop: the friction return map marched over sampled periods.

One kernel serves the four contact laws of DESIGN.md §3: the tangential
dimension ``d`` is 1 or 2 and a constant normal load is ``kn = 0``. For each
point, given time samples of the tangential relative displacement ``u`` (d
components) and of the normal one ``v``, the normal force is
``N_k = max(n0 + kn v_k, 0)`` and the tangential force follows

    predictor   Tp = T_{k-1} + kt * (u_k - u_{k-1})
    open        N_k = 0           ->  T_k = 0
    stick       |Tp| <= mu N_k    ->  T_k = Tp
    slip        otherwise         ->  T_k = mu N_k Tp / |Tp|   (radial return)

The march starts as if the previous sample had ``T = kt u_{N-1}``, so the
first predictor is ``kt u_0`` (the static part included: seed eqs. 26-28), and
repeats periods until the force at the end of a period repeats.

Derivatives are propagated forward through the same recursion (Petrov & Ewins
2003): ``G_k = dT_k / d(inputs)``, the inputs being the Fourier coefficients
of every component and ``n0``. The last period's ``G`` is projected onto the
harmonics with one matrix product per point.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

STICK, SLIP, OPEN = 0, 1, 2


@njit(cache=True, parallel=True, fastmath=False)
def march(u, v, kt, kn, mu, n0, E, A, has_normal, want_jac, max_periods, rtol,
          T_out, N_out, state_out, jT_out, jN_out, periods_out):  # pragma: no cover
    """March the return map of every point to its periodic steady state.

    u: (P, d, ns) tangential samples; v: (P, ns) normal samples;
    kt: (P, d); kn, mu, n0: (P,); E: (ns, nc) synthesis; A: (nc, ns) analysis.
    Outputs: T_out (P, d, ns), N_out (P, ns), state_out (P, ns) int8,
    jT_out (P, d, nc, m) and jN_out (P, nc, m) with m = (d + has_normal) nc + 1
    columns [u_1 coeffs, ..., u_d coeffs, (v coeffs), n0]; periods_out (P,).
    """
    P, d, ns = u.shape
    nc = E.shape[1]
    m = jT_out.shape[3]
    vcol = d * nc  # first v column
    for p in prange(P):
        G = np.zeros((ns, d * m)) if want_jac else np.zeros((1, 1))
        dT = np.zeros((d, m))
        dTp = np.zeros((d, m))
        T = np.empty(d)
        Tp = np.empty(d)
        Tend = np.empty(d)
        # Start: previous sample at k = ns - 1 with T = kt u (seed eq. 26).
        for j in range(d):
            T[j] = kt[p, j] * u[p, j, ns - 1]
            if want_jac:
                for c in range(nc):
                    dT[j, j * nc + c] = kt[p, j] * E[ns - 1, c]
        for j in range(d):
            Tend[j] = T[j]
        kprev = ns - 1
        periods = 0
        for period in range(max_periods):
            periods = period + 1
            scale = 0.0
            for k in range(ns):
                # predictor
                for j in range(d):
                    Tp[j] = T[j] + kt[p, j] * (u[p, j, k] - u[p, j, kprev])
                if want_jac:
                    for j in range(d):
                        for col in range(m):
                            dTp[j, col] = dT[j, col]
                        for c in range(nc):
                            dTp[j, j * nc + c] += kt[p, j] * (E[k, c] - E[kprev, c])
                N = n0[p] + kn[p] * v[p, k]
                if N <= 0.0:
                    N = 0.0
                    for j in range(d):
                        T[j] = 0.0
                    if want_jac:
                        for j in range(d):
                            for col in range(m):
                                dT[j, col] = 0.0
                    state_out[p, k] = OPEN
                else:
                    norm = 0.0
                    for j in range(d):
                        norm += Tp[j] * Tp[j]
                    norm = np.sqrt(norm)
                    lim = mu[p] * N
                    if norm <= lim:
                        for j in range(d):
                            T[j] = Tp[j]
                        if want_jac:
                            for j in range(d):
                                for col in range(m):
                                    dT[j, col] = dTp[j, col]
                        state_out[p, k] = STICK
                    else:
                        ratio = lim / norm
                        for j in range(d):
                            T[j] = ratio * Tp[j]
                        if want_jac:
                            # dT = ratio (I - n n^T) dTp + mu n dN,  n = Tp / |Tp|
                            for col in range(m):
                                proj = 0.0
                                for j in range(d):
                                    proj += Tp[j] * dTp[j, col]
                                proj /= norm
                                for j in range(d):
                                    dT[j, col] = ratio * (dTp[j, col] - Tp[j] / norm * proj)
                            for j in range(d):
                                g = mu[p] * Tp[j] / norm
                                if has_normal:
                                    for c in range(nc):
                                        dT[j, vcol + c] += g * kn[p] * E[k, c]
                                dT[j, m - 1] += g
                        state_out[p, k] = SLIP
                N_out[p, k] = N
                for j in range(d):
                    T_out[p, j, k] = T[j]
                    if abs(T[j]) > scale:
                        scale = abs(T[j])
                if mu[p] * N > scale:
                    scale = mu[p] * N
                if want_jac:
                    for j in range(d):
                        for col in range(m):
                            G[k, j * m + col] = dT[j, col]
                kprev = k
            # periodic when the state at the period's end repeats
            diff = 0.0
            for j in range(d):
                diff = max(diff, abs(T[j] - Tend[j]))
                Tend[j] = T[j]
            if diff <= rtol * scale or scale == 0.0:
                break
        periods_out[p] = periods
        if want_jac:
            J = np.dot(A, G)  # (nc, d m)
            for j in range(d):
                for c in range(nc):
                    for col in range(m):
                        jT_out[p, j, c, col] = J[c, j * m + col]
            # normal force: dN_k = [N_k > 0] (kn E_k on v, 1 on n0)
            for c in range(nc):
                for col in range(m):
                    jN_out[p, c, col] = 0.0
                for k in range(ns):
                    if N_out[p, k] > 0.0:
                        a = A[c, k]
                        if has_normal:
                            for c2 in range(nc):
                                jN_out[p, c, vcol + c2] += a * kn[p] * E[k, c2]
                        jN_out[p, c, m - 1] += a
