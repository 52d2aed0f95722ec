"""One period of the return map, sample by sample, with the derivatives carried forward
(Petrov & Ewins 2003): the predictor, stick (to rounding: STICK_SLACK), slip by radial
return with its flow derivative, lift-off and re-closing."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..states import SAMPLE_OPEN, SAMPLE_SLIP, SAMPLE_STICK

# A predictor this close to the limit, relative to the magnitudes it is computed from
# (mu N and kt |u|), sticks. A cycle stuck after slipping ("shakedown") touches the limit
# where it last slipped and comes back there each period with the rounding of a period's
# increments (~1e-15 of those magnitudes, measured to 4096 samples; at most ns * 1.1e-16,
# 5e-13): stick or slip decided by those bits would switch the sub-sample kink term on and
# off (an O(h^3) step in the forces), so the forces would not be differentiable there.
STICK_SLACK = 1e-11

# INLINED: the helpers a sample or a kink calls (here and in kinks) are inlined into their
# callers (numba inline="always"): a compiled call passes every array as a struct and counts
# its references, which cost more than a sample's work. 1,000 law-D points, H 3, 128
# samples, one thread, identical results: residual + Jacobian 172 -> 113 ms, residual alone
# 69 -> 38 ms; the serial kernel's first compile 42 -> 53 s. A call of more than 30
# arguments cannot be inlined (CPython 3.11 passes them as *args): the kinks take their
# arrays in named tuples (law, motion, dft, out, work).


@njit(cache=True)
def march_period(p, k0, count, was_open, motion, law, E, has_normal, want_jac, store, state,
                 samples, cn0, prev_slip):  # pragma: no cover
    """Advance the return map ``count`` samples from sample k0 (indices taken
    modulo ns), T and dT holding the state at the sample before; with ``store``
    each sample's dT goes to G. Returns the force scale met (max |T| and mu N),
    for the periodicity test. cn0: the n0 column of dT (< 0: its last);
    prev_slip: the sample before slipped (2D slip continues along the exact flow; a slip
    that starts between two stuck-then-slipping samples follows it from the onset).

    motion: (u (P, d, ns), v (P, ns)) the sampled relative motion; law: (kt (P, d), kn, mu,
    n0 (P,)); E (ns, nc): the synthesis; state: (T (d,), Tp (d,), dT (d, m), G (ns, d m)),
    the force, its predictor, their derivatives and the stored ones; samples: (T_out (P, d,
    ns), N_out (P, ns), state_out (P, ns)), the period's forces and states."""
    u, v = motion
    kt, kn, mu, n0 = law
    T, Tp, dT, G = state
    T_out, N_out, state_out = samples
    d, ns = u.shape[1], u.shape[2]
    nc = E.shape[1]
    m = dT.shape[1]
    if cn0 < 0:
        cn0 = m - 1
    vcol = d * nc
    scale = 0.0
    kprev = (k0 - 1) % ns
    N_prev = max(n0[p] + kn[p] * v[p, kprev], 0.0)
    for i in range(count):
        k = (k0 + i) % ns
        N = n0[p] + kn[p] * v[p, k]
        reclosed = was_open and N > 0.0
        if was_open and N > 0.0:
            _reclose(p, k, kprev, motion, law, E, want_jac, cn0, Tp, dT)
        else:
            # predictor; dT becomes dTp in place (a stuck sample touches nc columns)
            for j in range(d):
                Tp[j] = T[j] + kt[p, j] * (u[p, j, k] - u[p, j, kprev])
            if want_jac:
                for j in range(d):
                    for c in range(nc):
                        dT[j, j * nc + c] += kt[p, j] * (E[k, c] - E[kprev, c])
        if N <= 0.0:
            N = 0.0
            for j in range(d):
                T[j] = 0.0
            if want_jac:
                dT[:, :] = 0.0
            state_out[p, k] = SAMPLE_OPEN
        else:
            norm = 0.0
            for j in range(d):
                norm += Tp[j] * Tp[j]
            norm = np.sqrt(norm)
            lim = mu[p] * N
            stick = norm <= lim
            if not stick:
                # within rounding of the limit is stick (STICK_SLACK): a cycle left
                # touching the limit by a slip stays stuck there whatever its last bits
                slack = lim
                for j in range(d):
                    slack += kt[p, j] * abs(u[p, j, k])
                stick = norm <= lim + STICK_SLACK * slack
            if stick:
                for j in range(d):
                    T[j] = Tp[j]
                state_out[p, k] = SAMPLE_STICK
            elif d == 2 and not reclosed and _slip_flow(
                    p, k, kprev, law, E, has_normal, want_jac, lim, state, cn0,
                    -1.0 if prev_slip else mu[p] * N_prev):
                state_out[p, k] = SAMPLE_SLIP
            else:
                ratio = lim / norm
                for j in range(d):
                    T[j] = ratio * Tp[j]
                if want_jac:
                    # dT = ratio (I - n n^T) dTp + mu n dN,  n = Tp / |Tp|
                    if d == 1:
                        dT[0, :] = 0.0
                    else:
                        for col in range(m):
                            proj = 0.0
                            for j in range(d):
                                proj += Tp[j] * dT[j, col]
                            proj /= norm
                            for j in range(d):
                                dT[j, col] = ratio * (dT[j, col] - Tp[j] / norm * proj)
                    for j in range(d):
                        mun = mu[p] * Tp[j] / norm
                        if has_normal:
                            for c in range(nc):
                                dT[j, vcol + c] += mun * kn[p] * E[k, c]
                        dT[j, cn0] += mun
                state_out[p, k] = SAMPLE_SLIP
        was_open = N == 0.0
        prev_slip = state_out[p, k] == SAMPLE_SLIP
        N_prev = N
        N_out[p, k] = N
        for j in range(d):
            T_out[p, j, k] = T[j]
            if abs(T[j]) > scale:
                scale = abs(T[j])
        if mu[p] * N > scale:
            scale = mu[p] * N
        if store:
            for j in range(d):
                for col in range(m):
                    G[k, j * m + col] = dT[j, col]
        kprev = k
    return scale




@njit(inline="always")  # see INLINED in steps.py
def _slip_flow(p, k, kprev, law, E, has_normal, want_jac, L1, state, cn0,
               Lp):  # pragma: no cover
    """2D slip over the step from sample kprev to k, integrated exactly.

    With the predictor's increment q = kt du (linear in the step) and the limit
    L(s) linear in the step, slip keeps T = L t on the circle and turns t towards
    q: dt/ds = (I - t t^T) q / L(s), so the angle a between t and q obeys
    tan(a / 2) ~ exp(-|q| int ds / L). Radial return is the one-step backward
    Euler of this flow (first order in the sample spacing).

    Lp < 0: the slip continues from a slipping sample (T_prev on the circle).
    Lp >= 0: the previous sample stuck under its limit Lp (= mu N_prev); the
    predictor crosses the limit at the onset s in (0, 1], |T_prev + s q| = Lp + s
    (L1 - Lp), and the flow runs from there over the rest of the step. The update
    is then continuous in whether the previous sample slipped (an onset at s -> 0
    is a continued slip, one at s -> 1 radial return onto the circle): with radial
    return after a stuck sample and the flow after a slipping one, the period map
    jumped where a sample changed state, and the march could alternate between two
    cycles for ever.

    Applies while the motion pushes outwards (t . q >= L1 - L0, the slip rate
    >= 0) and the start angle is below 120 deg; returns False to leave the sample
    to radial return. T and dT (holding dTp on entry) of ``state`` receive the new state."""
    kt, kn, mu, _ = law
    T, Tp, dT, _ = state
    nc = E.shape[1]
    m = dT.shape[1]
    vcol = 2 * nc
    Q0, Q1 = Tp[0] - T[0], Tp[1] - T[1]  # the whole step's increment
    s = 0.0
    dS = L1 - Lp
    if Lp >= 0.0:  # the onset: f(s) = |T + s Q|^2 - (Lp + s dS)^2 = 0, rising through 0
        a = Q0 * Q0 + Q1 * Q1 - dS * dS
        b = T[0] * Q0 + T[1] * Q1 - Lp * dS
        c = T[0] * T[0] + T[1] * T[1] - Lp * Lp
        if c < 0.0:
            disc = max(b * b - a * c, 0.0)
            den = b + np.sqrt(disc)
            if den <= 0.0:
                return False
            s = min(-c / den, 1.0)
    Ts0, Ts1 = T[0] + s * Q0, T[1] + s * Q1
    q0, q1 = (1.0 - s) * Q0, (1.0 - s) * Q1
    L0 = np.sqrt(Ts0 * Ts0 + Ts1 * Ts1)
    nq = np.sqrt(q0 * q0 + q1 * q1)
    if L0 <= 0.0 or L1 <= 0.0 or nq <= 1e-14 * L1:
        return False
    t0, t1 = Ts0 / L0, Ts1 / L0
    if t0 * q0 + t1 * q1 < L1 - L0:
        return False
    h0, h1 = q0 / nq, q1 / nq
    c0 = t0 * h0 + t1 * h1
    if c0 <= -0.5:
        return False
    p0, p1 = t0 - c0 * h0, t1 - c0 * h1
    np_ = np.sqrt(p0 * p0 + p1 * p1)
    tau0 = np_ / (1.0 + c0)
    dL = L1 - L0
    general = abs(dL) > 1e-8 * (L0 + L1)
    Iint = np.log(L1 / L0) / dL if general else 2.0 / (L0 + L1)
    Ex = np.exp(-nq * Iint)
    tau1 = tau0 * Ex
    den1 = 1.0 + tau1 * tau1
    C = (1.0 - tau1 * tau1) / den1
    beta = 2.0 * Ex / ((1.0 + c0) * den1)
    r0, r1 = C * h0 + beta * p0, C * h1 + beta * p1
    T[0], T[1] = L1 * r0, L1 * r1
    if not want_jac:
        return True
    # the update depends on five numbers (T_start, q, L1; L0 = |T_start|): its local
    # Jacobian once per sample, then applied to every column (as cheap as radial return)
    flow = (t0, t1, L0, L1, h0, h1, nq, c0, p0, p1, np_, Iint, general, Ex, tau0, tau1, den1,
            C, beta, r0, r1)
    a00, a10 = _flow_derivative(1.0, 0.0, 0.0, 0.0, 0.0, flow)
    a01, a11 = _flow_derivative(0.0, 1.0, 0.0, 0.0, 0.0, flow)
    b00, b10 = _flow_derivative(0.0, 0.0, 1.0, 0.0, 0.0, flow)
    b01, b11 = _flow_derivative(0.0, 0.0, 0.0, 1.0, 0.0, flow)
    e0, e1 = _flow_derivative(0.0, 0.0, 0.0, 0.0, 1.0, flow)
    # the onset moves with the inputs: ds = -(df) / (df/ds), f as above
    onset = Lp >= 0.0 and s > 0.0
    fs = 2.0 * (Ts0 * Q0 + Ts1 * Q1 - L0 * dS) if onset else 1.0
    for col in range(m):
        # derivatives of the step's increment Q (u columns) and of T_prev (dT holds dTp
        # = dT_prev + dQ); of the limits at both ends (v columns, n0)
        dQ0 = dQ1 = 0.0
        if col < nc:
            dQ0 = kt[p, 0] * (E[k, col] - E[kprev, col])
        elif col < 2 * nc:
            dQ1 = kt[p, 1] * (E[k, col - nc] - E[kprev, col - nc])
        dP0, dP1 = dT[0, col] - dQ0, dT[1, col] - dQ1
        dL1 = dLp = 0.0
        if col == cn0:
            dL1 = dLp = mu[p]
        elif has_normal and vcol <= col < vcol + nc:
            dL1 = mu[p] * kn[p] * E[k, col - vcol]
            dLp = mu[p] * kn[p] * E[kprev, col - vcol]
        ds = 0.0
        if onset:
            df = 2.0 * (Ts0 * (dP0 + s * dQ0) + Ts1 * (dP1 + s * dQ1)
                        - L0 * ((1.0 - s) * dLp + s * dL1))
            ds = -df / fs if fs != 0.0 else 0.0
        dT0 = dP0 + ds * Q0 + s * dQ0
        dT1 = dP1 + ds * Q1 + s * dQ1
        dq0 = (1.0 - s) * dQ0 - ds * Q0
        dq1 = (1.0 - s) * dQ1 - ds * Q1
        dT[0, col] = a00 * dT0 + a01 * dT1 + b00 * dq0 + b01 * dq1 + e0 * dL1
        dT[1, col] = a10 * dT0 + a11 * dT1 + b10 * dq0 + b11 * dq1 + e1 * dL1
    return True


@njit(inline="always")  # see INLINED in steps.py
def _flow_derivative(dT0, dT1, dq0, dq1, dL1, flow):  # pragma: no cover
    """Directional derivative of the exact 2D slip update (see _slip_flow) along
    (dT_prev, dq, dL1); returns the change of the new force (2 components). flow: the
    update's intermediate values, as _slip_flow names them."""
    (t0, t1, L0, L1, h0, h1, nq, c0, p0, p1, np_, Iint, general, Ex, tau0, tau1, den, C, beta,
     r0, r1) = flow
    dL0 = t0 * dT0 + t1 * dT1
    dt0, dt1 = (dT0 - t0 * dL0) / L0, (dT1 - t1 * dL0) / L0
    dnq = h0 * dq0 + h1 * dq1
    dh0, dh1 = (dq0 - h0 * dnq) / nq, (dq1 - h1 * dnq) / nq
    dc0 = dt0 * h0 + dt1 * h1 + t0 * dh0 + t1 * dh1
    dp0, dp1 = dt0 - dc0 * h0 - c0 * dh0, dt1 - dc0 * h1 - c0 * dh1
    dnp = (p0 * dp0 + p1 * dp1) / np_ if np_ > 0.0 else 0.0
    dtau0 = dnp / (1.0 + c0) - np_ * dc0 / (1.0 + c0) ** 2
    if general:
        dL = L1 - L0
        dI = (Iint - 1.0 / L0) / dL * dL0 + (1.0 / L1 - Iint) / dL * dL1
    else:
        dI = -2.0 / (L0 + L1) ** 2 * (dL0 + dL1)
    dlogEx = -(Iint * dnq + nq * dI)  # not dEx / Ex: Ex underflows to 0 on a long slip
    dEx = Ex * dlogEx
    dtau1 = dtau0 * Ex + tau0 * dEx
    dC = -4.0 * tau1 / (den * den) * dtau1
    dbeta = beta * (dlogEx - dc0 / (1.0 + c0) - 2.0 * tau1 * dtau1 / den)
    dr0 = dC * h0 + C * dh0 + dbeta * p0 + beta * dp0
    dr1 = dC * h1 + C * dh1 + dbeta * p1 + beta * dp1
    return dL1 * r0 + L1 * dr0, dL1 * r1 + L1 * dr1


@njit(inline="always")  # see INLINED in steps.py
def _reclose(p, k, kprev, motion, law, E, want_jac, cn0, Tp, dT):
    """Predictor of a contact that closes inside (kprev, k): T was 0 and sticking
    starts where the normal gap closes, ``Tp = kt (1 - s) (u_k - u_kprev)`` with
    ``s = Nu_prev / (Nu_prev - Nu_k)``, ``Nu = n0 + kn v``. dT (zero while open)
    becomes dTp."""  # pragma: no cover
    u, v = motion
    kt, kn, _, n0 = law
    d = Tp.size
    nc = E.shape[1]
    vcol = d * nc
    nu0 = n0[p] + kn[p] * v[p, kprev]
    nu1 = n0[p] + kn[p] * v[p, k]
    den = nu0 - nu1
    s = nu0 / den
    for j in range(d):
        Tp[j] = (1.0 - s) * kt[p, j] * (u[p, j, k] - u[p, j, kprev])
    if want_jac:
        # ds = (-nu1 dnu0 + nu0 dnu1) / den^2, dnu = kn E (v columns) + 1 (n0 column)
        for j in range(d):
            du = kt[p, j] * (u[p, j, k] - u[p, j, kprev])
            for c in range(nc):
                dT[j, j * nc + c] = (1.0 - s) * kt[p, j] * (E[k, c] - E[kprev, c])
                ds = kn[p] * (-nu1 * E[kprev, c] + nu0 * E[k, c]) / (den * den)
                dT[j, vcol + c] = -du * ds
            dT[j, cn0] = -du * (nu0 - nu1) / (den * den)
