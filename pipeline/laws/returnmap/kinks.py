"""Sub-sample corrections: each stick/slip or contact transition located between two
samples, and the trapezoid rule's kink term removed (O(h^3), continuous in the transition's
position, differentiated in closed form)."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..states import SAMPLE_OPEN, SAMPLE_SLIP, SAMPLE_STICK


@njit(inline="always")  # see INLINED in steps.py
def _coeff_weight(c, theta, ns, corder, ckind):
    """Analysis weight a_c(theta) and its derivative d a_c / d theta."""  # pragma: no cover
    if ckind[c] == 0:
        return 1.0 / ns, 0.0
    n = corder[c]
    if ckind[c] == 1:
        return 2.0 / ns * np.cos(n * theta), -2.0 / ns * n * np.sin(n * theta)
    return 2.0 / ns * np.sin(n * theta), 2.0 / ns * n * np.cos(n * theta)


@njit(inline="always")  # see INLINED in steps.py
def _slopes(c, theta, corder, ckind):
    """d/dtheta and d2/dtheta2 of the basis function of coefficient c."""  # pragma: no cover
    if ckind[c] == 0:
        return 0.0, 0.0
    n = corder[c]
    if ckind[c] == 1:
        return -n * np.sin(n * theta), -n * n * np.cos(n * theta)
    return n * np.cos(n * theta), -n * n * np.sin(n * theta)


@njit(cache=True)
def kink_corrections(p, g, law, motion, dft, has_normal, want_jac, out):  # pragma: no cover
    """Add the sub-sample kink corrections of one point's final period.

    The periodic trapezoid rule across a slope jump J (per radian) at fraction
    s of an interval errs by ``(s (1 - s) - 1/6) h^2 J / 2`` (Euler-Maclaurin);
    that is subtracted. The kink is located on the linear interpolant of the
    samples; J comes from the exact slopes of the trigonometric inputs there,
    so the correction varies continuously as a kink crosses a sample.
    g: (P, c, nc) input coefficients; law: (kt, kn, mu, n0) per point; motion: (u, v), the
    sampled relative motion; dft: (E, corder, ckind), the samples' Fourier rows and their
    orders and kinds; out: (T_out, N_out, state_out, G, F_out, J_out, D_out), the march's
    results and the coefficients and derivatives the corrections are added to."""
    u = motion[0]
    state_out, J_out = out[2], out[5]
    d, ns = u.shape[1], u.shape[2]
    m = J_out.shape[3] + 1
    rows = d + 1
    jump = np.zeros(rows)
    djump = np.zeros((rows, m))
    ds = np.zeros(m)
    a = np.zeros(d)
    da = np.zeros((d, m))
    nvec = np.zeros(d)
    dn = np.zeros((d, m))
    up = np.zeros(d)  # u'(theta_c)
    dup = np.zeros((d, m))
    dvp = np.zeros(m)
    upp = np.zeros(d)  # u''(theta_c)
    work = (jump, djump, ds, a, da, nvec, dn, up, dup, dvp, upp)
    for k in range(ns):
        kprev = k - 1 if k > 0 else ns - 1
        s0, s1 = state_out[p, kprev], state_out[p, k]
        first, kinds = 0, 1
        if s0 == SAMPLE_STICK and s1 == SAMPLE_SLIP:
            first = 1
        elif has_normal and s0 != SAMPLE_OPEN and s1 == SAMPLE_OPEN:
            # a stuck sample before an opening one: the force reaches the shrinking cone
            # and slides before the contact opens (two kinks); with the stick -> slip one
            # left out, the correction jumped as that kink crossed the sample
            first, kinds = (1, 2) if s0 == SAMPLE_STICK else (2, 1)
        elif has_normal and s0 == SAMPLE_OPEN and s1 != SAMPLE_OPEN:
            first = 3
        if first == 0:
            continue
        for q in range(kinds):
            kind = first + q
            _kink(p, k, kprev, kind, g, law, motion, dft, has_normal, want_jac, out, work)


@njit(inline="always")  # see INLINED in steps.py
def _kink(p, k, kprev, kind, g, law, motion, dft, has_normal, want_jac, out, work
          ):  # pragma: no cover
    """One kink of ``kind`` (1 stick -> slip, 2 opening, 3 closing) in the interval
    (kprev, k) of point p: its correction added to F_out (and J_out, D_out); ``work``: the
    caller's work arrays (jump, djump, ds, a, da, nvec, dn, up, dup, dvp, upp); law,
    motion, dft, out: as :func:`kink_corrections`'s."""
    jump, djump, ds, a, da, nvec, dn, up, dup, dvp, upp = work
    kt, kn, mu, n0 = law
    u, v = motion
    E, corder, ckind = dft
    T_out, N_out, state_out, G, F_out, J_out, D_out = out
    d, ns, nc = u.shape[1], u.shape[2], E.shape[1]
    m = J_out.shape[3] + 1
    vcol, rows, h = d * nc, d + 1, 2.0 * np.pi / ns
    last = rows if has_normal else d
    if want_jac:
        djump[:, :] = 0.0
        ds[:] = 0.0
        da[:, :] = 0.0
        dn[:, :] = 0.0
    for j in range(d):
        a[j] = kt[p, j] * (u[p, j, k] - u[p, j, kprev])  # stick slope per unit s
        if want_jac:
            for c in range(nc):
                da[j, j * nc + c] = kt[p, j] * (E[k, c] - E[kprev, c])
    if kind == 1:
        s = _crossing(p, k, kprev, a, da, kn, mu, n0, v, E, has_normal, want_jac, T_out, N_out,
                      G, ds, nvec, dn)
    else:
        nu0 = n0[p] + kn[p] * v[p, kprev]
        nu1 = n0[p] + kn[p] * v[p, k]
        den = nu0 - nu1  # > 0 opening, < 0 closing
        s = nu0 / den
        if want_jac:
            for c in range(nc):
                ds[vcol + c] = kn[p] * (-nu1 * E[kprev, c] + nu0 * E[k, c]) / (den * den)
            ds[m - 1] = 1.0 / den
    theta = ((kprev if k > 0 else -1) + s) * h
    # exact slopes of the inputs at the kink, and their derivatives
    vp, vpp = 0.0, 0.0
    for j in range(d):
        up[j] = 0.0
        upp[j] = 0.0
    for c in range(nc):
        d1, d2 = _slopes(c, theta, corder, ckind)
        for j in range(d):
            up[j] += g[p, j, c] * d1
            upp[j] += g[p, j, c] * d2
        if has_normal:
            vp += g[p, d, c] * d1
            vpp += g[p, d, c] * d2
    if want_jac:
        for col in range(m):
            for j in range(d):
                dup[j, col] = upp[j] * h * ds[col]
            dvp[col] = vpp * h * ds[col]
        for c in range(nc):
            d1, _ = _slopes(c, theta, corder, ckind)
            for j in range(d):
                dup[j, j * nc + c] += d1
            if has_normal:
                dvp[vcol + c] += d1
    for r in range(rows):
        jump[r] = 0.0
    if kind == 1:
        # stick slope kt u'; slip slope mu N' n + (I - n n^T) kt u' (slip flow)
        # -> J = n (mu N' - n . kt u')
        bp = mu[p] * kn[p] * vp if has_normal else 0.0
        na = 0.0
        for j in range(d):
            na += nvec[j] * kt[p, j] * up[j]
        for j in range(d):
            jump[j] = nvec[j] * (bp - na)
        if want_jac:
            for col in range(m):
                dbp = mu[p] * kn[p] * dvp[col] if has_normal else 0.0
                dna = 0.0
                for j in range(d):
                    dna += dn[j, col] * kt[p, j] * up[j] + nvec[j] * kt[p, j] * dup[j, col]
                for j in range(d):
                    djump[j, col] = dn[j, col] * (bp - na) + nvec[j] * (dbp - dna)
    else:
        ref = kprev if kind == 2 else k
        sgn = -1.0 if kind == 2 else 1.0  # N loses / gains its slope kn v'
        jump[d] = sgn * kn[p] * vp
        tn = 0.0
        for j in range(d):
            tn += T_out[p, j, ref] * T_out[p, j, ref]
        tn = np.sqrt(tn)
        for j in range(d):
            nvec[j] = T_out[p, j, ref] / tn if tn > 0.0 else 0.0
        stick_after = kind == 3 and state_out[p, k] == SAMPLE_STICK
        for j in range(d):
            # T slides on mu N into an opening; sticks (kt u') or slides out of a closing
            jump[j] = kt[p, j] * up[j] if stick_after else sgn * mu[p] * kn[p] * vp * nvec[j]
        if want_jac:
            for col in range(m):
                djump[d, col] = sgn * kn[p] * dvp[col]
                proj = 0.0
                for j in range(d):
                    proj += nvec[j] * G[ref, j * m + col]
                for j in range(d):
                    if stick_after:
                        djump[j, col] = kt[p, j] * dup[j, col]
                    else:
                        dnj = (G[ref, j * m + col] - nvec[j] * proj) / tn if tn > 0.0 else 0.0
                        djump[j, col] = sgn * mu[p] * kn[p] * (dvp[col] * nvec[j] + vp * dnj)
    # integral correction h^2 J (1/6 - s (1 - s)) / 2 -> coefficients a_c(theta) / h times it
    wk = h * (1.0 / 6.0 - s * (1.0 - s)) / 2.0
    for c in range(nc):
        wc, dwc = _coeff_weight(c, theta, ns, corder, ckind)
        for j in range(last):
            F_out[p, j, c] += wc * wk * jump[j]
            if want_jac:
                for col in range(m):
                    dwk = h * (2.0 * s - 1.0) / 2.0 * ds[col]
                    val = (wc * (wk * djump[j, col] + dwk * jump[j])
                           + dwc * h * ds[col] * wk * jump[j])
                    if col == m - 1:
                        D_out[p, j, c] += val
                    else:
                        J_out[p, j, c, col] += val


@njit(inline="always")  # see INLINED in steps.py
def _crossing(p, k, kprev, a, da, kn, mu, n0, v, E, has_normal, want_jac, T_out, N_out,
              G, ds, nvec, dn):  # pragma: no cover
    """Fraction s of (kprev, k) where the linear predictor ``T_prev + s a``
    from a stuck sample reaches the limit ``L0 + s b`` (b = mu (N_k - N_prev));
    fills ds, the direction n = T_c / L_c there and dn. Into an opening sample (N_k = 0)
    the limit is that of the unclipped normal force n0 + kn v_k < 0, which reaches zero
    where the contact opens: the force slides down the shrinking cone before then."""
    d = a.size
    nc = E.shape[1]
    m = ds.size
    vcol = d * nc
    opening = has_normal and N_out[p, k] <= 0.0
    L0 = mu[p] * N_out[p, kprev]
    b = mu[p] * (n0[p] + kn[p] * v[p, k] if opening else N_out[p, k]) - L0
    qa, qb, qc = -b * b, -L0 * b, -L0 * L0
    for j in range(d):
        t0 = T_out[p, j, kprev]
        qa += a[j] * a[j]
        qb += t0 * a[j]
        qc += t0 * t0
    # f(s) = qa s^2 + 2 qb s + qc: f(0) < 0 (stuck at kprev) < f(1) (slip at k),
    # one root in (0, 1], in a cancellation-free form
    den = qb + np.sqrt(max(qb * qb - qa * qc, 0.0))
    s = min(max(-qc / den, 0.0), 1.0) if den > 0.0 else 1.0
    if opening and L0 > 0.0:
        # into an opening the root lies in (0, s*], s* where the cone closes (L0 + s* b = 0);
        # next to s* (a contact stuck since it closed, grazing: T and the cone vanish
        # together) the form above loses s to cancellation, and n = T_c / L_c with it:
        # solved instead for sg = s* - s in |T* - sg a| = -sg b, T* = T_prev + s* a
        # (f(sg = 0) = |T*|^2 >= 0 > f(sg = s*), one root between, cancellation-free)
        sst = min(L0 / -b, 1.0) if b < 0.0 else 1.0
        ra, rb, rc = -b * b, 0.0, 0.0
        for j in range(d):
            ts = T_out[p, j, kprev] + sst * a[j]
            ra += a[j] * a[j]
            rb += ts * a[j]
            rc += ts * ts
        den = rb + np.sqrt(max(rb * rb - ra * rc, 0.0))
        sg = min(max(rc / den, 0.0), sst) if den > 0.0 else 0.0
        s = min(sst - sg, 1.0)
    lc = L0 + s * b
    dfs = -lc * b
    for j in range(d):
        tc = T_out[p, j, kprev] + s * a[j]
        dfs += tc * a[j]
        nvec[j] = tc / lc if lc > 0.0 else 0.0
    if not want_jac:
        return s
    for col in range(m):
        dl0 = 0.0
        dl1 = 0.0
        if col == m - 1:
            dl0 = mu[p] if N_out[p, kprev] > 0.0 else 0.0
            dl1 = mu[p] if (N_out[p, k] > 0.0 or opening) else 0.0
        elif has_normal and vcol <= col < vcol + nc:
            c = col - vcol
            dl0 = mu[p] * kn[p] * E[kprev, c]
            dl1 = mu[p] * kn[p] * E[k, c]
        db = dl1 - dl0
        # implicit derivative of the crossing |T_prev + s a|^2 = (L0 + s b)^2
        num = -lc * (dl0 + s * db)
        for j in range(d):
            tc = T_out[p, j, kprev] + s * a[j]
            num += tc * (G[kprev, j * m + col] + s * da[j, col])
        ds[col] = -num / dfs if dfs != 0.0 else 0.0
        dlc = dl0 + s * db + ds[col] * b
        for j in range(d):
            dtc = G[kprev, j * m + col] + s * da[j, col] + ds[col] * a[j]
            dn[j, col] = (dtc - nvec[j] * dlc) / lc if lc > 0.0 else 0.0
    return s
