"""The compiled march: the return map of each contact point, the Newmark step with its
Newton iteration, the events (stick/slip, lift-off, re-contact) located inside a step and
the step split there (see the package for the scheme).

The kernels take their arrays in tuples named by what they hold (numba passes a tuple of
arrays as one argument, unpacked at no cost):

    structure   (M, C, K): the lumped model's matrices (n, n)
    contacts    (B, row0, dim, normal, kt, kn, mu, n0): the points' kinematics (B (R, n),
                their first rows, tangential dimension, whether the normal load varies)
                and laws (kt (P, 2), kn, mu, n0 (P,))
    committed   (q, v, a, Tc, Nc, Nrc, gc, sc): the accepted state, advanced in place
    trial       (a1, qt, vt, dq, Tt, Nt, Nrt, st, gt): a step's end state under Newton
    scratch     (work (3, n), J (n, n), gq (R,), Dp (3, 3), tmp (2,)): work arrays
    history     (q_out, v_out, T_out, N_out, s_out, g_out, e_out, wf_out, wn_out): the
                states 0..n and the cumulative energies
"""

from __future__ import annotations

import numpy as np
from numba import njit


# =================================================================== kernel
@njit(cache=True)
def _point_law(p, gt, gc, Tc, Nc, Nrc, kt, kn_, mu_, n0_, d, has_n, T, D):  # pragma: no cover
    """Return map of one point from its committed state to the trial g.

    Point p of: gt, gc (P, 3) trial and committed ``[u_1, u_2, v]``; Tc (P, 2)
    committed T; Nc, Nrc (P,) committed N and ``n0 + kn v``; kt (P, 2), kn,
    mu, n0 (P,) parameters. Writes T (2,) and D (3, 3) =
    d[T_1, T_2, N] / d[u_1, u_2, v]; returns (N, n0 + kn v, state code)."""
    for i in range(3):
        for j in range(3):
            D[i, j] = 0.0
    T[0] = 0.0
    T[1] = 0.0
    kn = kn_[p]
    mu = mu_[p]
    nr = n0_[p] + kn * gt[p, 2] if has_n else n0_[p]
    if nr <= 0.0:
        return 0.0, nr, 2  # OPEN
    if has_n:
        D[2, 2] = kn
    tp0 = 0.0
    tp1 = 0.0
    if has_n and Nc[p] <= 0.0:
        # re-contact inside the step at fraction s; stick starts where the gap closed
        nrc = Nrc[p]
        s = nrc / (nrc - nr)
        dsdv = nrc * kn / ((nrc - nr) * (nrc - nr))
        for j in range(d):
            du = gt[p, j] - gc[p, j]
            tj = kt[p, j] * (1.0 - s) * du
            D[j, j] = kt[p, j] * (1.0 - s)
            D[j, 2] = -kt[p, j] * du * dsdv
            if j == 0:
                tp0 = tj
            else:
                tp1 = tj
    else:
        tp0 = Tc[p, 0] + kt[p, 0] * (gt[p, 0] - gc[p, 0])
        D[0, 0] = kt[p, 0]
        if d == 2:
            tp1 = Tc[p, 1] + kt[p, 1] * (gt[p, 1] - gc[p, 1])
            D[1, 1] = kt[p, 1]
    norm = np.sqrt(tp0 * tp0 + tp1 * tp1)
    lim = mu * nr
    if norm <= lim:
        T[0] = tp0
        T[1] = tp1
        return nr, nr, 0  # STICK
    ratio = lim / norm
    n_0 = tp0 / norm
    n_1 = tp1 / norm
    T[0] = ratio * tp0
    T[1] = ratio * tp1
    for col in range(3):
        proj = n_0 * D[0, col] + n_1 * D[1, col]
        D[0, col] = ratio * (D[0, col] - n_0 * proj)
        D[1, col] = ratio * (D[1, col] - n_1 * proj)
    if has_n:
        D[0, 2] += mu * n_0 * kn
        D[1, 2] += mu * n_1 * kn
    return nr, nr, 1  # SLIP


@njit(cache=True)
def _solve_inplace(A, b):  # pragma: no cover
    """Solve A x = b by Gaussian elimination with partial pivoting; x into b,
    A destroyed. Small dense systems: no allocation, no LAPACK call overhead."""
    n = b.size
    for k in range(n):
        piv = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                piv = i
        if piv != k:
            for j in range(n):
                A[k, j], A[piv, j] = A[piv, j], A[k, j]
            b[k], b[piv] = b[piv], b[k]
        akk = A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] / akk
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
                b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        s = b[k]
        for j in range(k + 1, n):
            s -= A[k, j] * b[j]
        b[k] = s / A[k, k]


@njit(cache=True)
def _relative_motion(B, x, row0, dim, normal, gq, out):  # pragma: no cover
    """Per point (u1, u2, v) of the DOF vector x (displacements or velocities): gq = B x,
    then out[p] = its point's rows, 0 for a component the point does not have."""
    n = x.size
    for i in range(gq.size):
        s = 0.0
        for j in range(n):
            s += B[i, j] * x[j]
        gq[i] = s
    for p in range(row0.size):
        r0 = row0[p]
        d = dim[p]
        out[p, 0] = gq[r0]
        out[p, 1] = gq[r0 + 1] if d == 2 else 0.0
        out[p, 2] = gq[r0 + d] if normal[p] else 0.0


@njit(cache=True)
def _residual(a1, h, Fk, committed, structure, contacts, trial, scratch, want_J, r
              ):  # pragma: no cover
    """Residual ``M a1 + C v1 + K q1 + B^T f(B q1) - F`` of a Newmark step of
    length h written in the end acceleration a1 (no cancellation however short
    the step): ``dq = h v + h^2 (a + a1) / 4``, ``q1 = q + dq``,
    ``v1 = v + h (a + a1) / 2``. Fills qt, vt, dq, the trial contact state
    (Tt, Nt, Nrt, st, gt) and, if want_J, J = dR/da1 (``scratch``'s). Returns
    the force scale (largest term)."""
    q, v, a, Tc, Nc, Nrc, gc = (committed[0], committed[1], committed[2], committed[3],
                                committed[4], committed[5], committed[6])
    M, C, K = structure
    B, row0, dim, normal, kt, kn, mu, n0 = contacts
    qt, vt, dq, Tt, Nt, Nrt, st, gt = (trial[1], trial[2], trial[3], trial[4], trial[5],
                                       trial[6], trial[7], trial[8])
    J, gq, Dp, tmp = scratch[1], scratch[2], scratch[3], scratch[4]
    n = q.size
    h4 = 0.25 * h * h
    for j in range(n):
        dq[j] = h * v[j] + h4 * (a[j] + a1[j])
        qt[j] = q[j] + dq[j]
        vt[j] = v[j] + 0.5 * h * (a[j] + a1[j])
    scale = 1e-300
    for i in range(n):
        ma = 0.0
        cv = 0.0
        kq = 0.0
        for j in range(n):
            ma += M[i, j] * a1[j]
            cv += C[i, j] * vt[j]
            kq += K[i, j] * qt[j]
            if want_J:
                J[i, j] = M[i, j] + 0.5 * h * C[i, j] + h4 * K[i, j]
        r[i] = ma + cv + kq - Fk[i]
        scale = max(scale, abs(ma), abs(cv), abs(kq), abs(Fk[i]))
    _relative_motion(B, qt, row0, dim, normal, gq, gt)
    for p in range(row0.size):
        r0 = row0[p]
        d = dim[p]
        hn = normal[p]
        N, nr, s = _point_law(p, gt, gc, Tc, Nc, Nrc, kt, kn, mu, n0, d, hn, tmp, Dp)
        Tt[p, 0] = tmp[0]
        Tt[p, 1] = tmp[1]
        Nt[p] = N
        Nrt[p] = nr
        st[p] = s
        c = d + hn
        for a_ in range(c):
            fa = tmp[a_] if a_ < d else N
            if fa != 0.0:
                for i in range(n):
                    r[i] += B[r0 + a_, i] * fa
            scale = max(scale, abs(fa))
        if want_J and s != 2:
            for a_ in range(c):
                ia = a_ if a_ < d else 2
                for b_ in range(c):
                    ib = b_ if b_ < d else 2
                    dab = Dp[ia, ib] * h4
                    if dab == 0.0:
                        continue
                    for i in range(n):
                        bai = B[r0 + a_, i] * dab
                        if bai == 0.0:
                            continue
                        for j in range(n):
                            J[i, j] += bai * B[r0 + b_, j]
    return scale


@njit(cache=True)
def _solve_step(h, Fk, committed, structure, contacts, newton, trial, scratch
                ):  # pragma: no cover
    """Newton on one Newmark step of length h from the committed state (the
    unknown is the end acceleration a1; predictor a1 = a). On success the end
    state is in a1, qt, vt, dq and the trial contact arrays. Returns
    (iterations, converged). newton: (rtol, max_iter)."""
    a = committed[2]
    a1 = trial[0]
    rtol, max_iter = newton
    J = scratch[1]
    n = a.size
    r, da, guess = scratch[0][0], scratch[0][1], scratch[0][2]
    for j in range(n):
        a1[j] = a[j]
    small = False
    for it in range(max_iter):
        scale = _residual(a1, h, Fk, committed, structure, contacts, trial, scratch, True, r)
        rn = 0.0
        for j in range(n):
            rn = max(rn, abs(r[j]))
        if rn <= rtol * scale or small:
            return it + 1, True
        for j in range(n):
            da[j] = -r[j]
        _solve_inplace(J, da)
        alpha = 1.0
        if it >= 6:  # damp a Newton cycle between two active sets
            for _ in range(12):
                for j in range(n):
                    guess[j] = a1[j] + alpha * da[j]
                _residual(guess, h, Fk, committed, structure, contacts, trial, scratch, False,
                          r)
                rt = 0.0
                for j in range(n):
                    rt = max(rt, abs(r[j]))
                if rt < (1.0 - 1e-4 * alpha) * rn:
                    break
                alpha *= 0.5
        big = 1e-300
        step = 0.0
        for j in range(n):
            a1[j] += alpha * da[j]
            big = max(big, abs(a1[j]))
            step = max(step, abs(alpha * da[j]))
        small = step <= 1e-15 * big
    return max_iter, False


@njit(cache=True)
def _hermite(s, h, g0, g1, d0, d1):  # pragma: no cover
    """Cubic Hermite value and time derivative at fraction s of a step of
    length h between (g0, rate d0) and (g1, rate d1)."""
    s2 = s * s
    s3 = s2 * s
    val = ((2 * s3 - 3 * s2 + 1) * g0 + (s3 - 2 * s2 + s) * h * d0
           + (-2 * s3 + 3 * s2) * g1 + (s3 - s2) * h * d1)
    der = ((6 * s2 - 6 * s) * g0 + (3 * s2 - 4 * s + 1) * h * d0
           + (-6 * s2 + 6 * s) * g1 + (3 * s2 - 2 * s) * h * d1) / h
    return val, der


@njit(cache=True)
def _event_value(kind, s, h, p, gc, gt, gd0, gd1, kt, kn, mu, n0, dim, normal,
                 Tc):  # pragma: no cover
    """Event function of one point at fraction s of the step (a sign change is
    a transition): kind 0 ``n0 + kn v`` (closing, opening); kind 1
    ``|Tp| - mu N`` (stick -> slip); kind 2 ``kt u' . e - mu kn v'`` with e the
    slip direction (slip -> stick: the force no longer keeps up with the
    slip limit, e.g. a reversal)."""
    vv, vd = _hermite(s, h, gc[p, 2], gt[p, 2], gd0[p, 2], gd1[p, 2])
    if normal[p] == 0:
        vv = 0.0
        vd = 0.0
    nr = n0[p] + kn[p] * vv
    if kind == 0:
        return nr
    if kind == 1:
        tn = 0.0
        for j in range(dim[p]):
            u, _ = _hermite(s, h, gc[p, j], gt[p, j], gd0[p, j], gd1[p, j])
            tj = Tc[p, j] + kt[p, j] * (u - gc[p, j])
            tn += tj * tj
        return np.sqrt(tn) - mu[p] * nr
    tnorm = np.sqrt(Tc[p, 0] ** 2 + Tc[p, 1] ** 2)
    f = 0.0
    for j in range(dim[p]):
        _, ud = _hermite(s, h, gc[p, j], gt[p, j], gd0[p, j], gd1[p, j])
        f += kt[p, j] * ud * Tc[p, j] / tnorm
    return f - mu[p] * kn[p] * vd


@njit(cache=True)
def _first_event(h, committed, contacts, trial, gd0, gd1, gq):  # pragma: no cover
    """Earliest contact transition inside a step of length h, as a fraction in
    (0, 1) located by bisection on the cubic Hermite interpolant of the
    relative motion; 2.0 if no event function changes sign over the step."""
    v, Tc, Nc, gc, sc = committed[1], committed[3], committed[4], committed[6], committed[7]
    B, row0, dim, normal, kt, kn, mu, n0 = contacts
    vt, gt = trial[2], trial[8]
    _relative_motion(B, v, row0, dim, normal, gq, gd0)
    _relative_motion(B, vt, row0, dim, normal, gq, gd1)
    first = 2.0
    for p in range(row0.size):
        for kind in range(3):
            if kind == 0 and normal[p] == 0:
                continue
            if kind == 1 and not (Nc[p] > 0.0 and sc[p] == 0):
                continue
            if kind == 2 and not (Nc[p] > 0.0 and sc[p] == 1
                                  and Tc[p, 0] ** 2 + Tc[p, 1] ** 2 > 0.0):
                continue
            f0 = _event_value(kind, 0.0, h, p, gc, gt, gd0, gd1, kt, kn, mu, n0, dim,
                              normal, Tc)
            f1 = _event_value(kind, 1.0, h, p, gc, gt, gd0, gd1, kt, kn, mu, n0, dim,
                              normal, Tc)
            if (f0 > 0.0) == (f1 > 0.0):
                continue
            lo, hi = 0.0, 1.0
            for _ in range(50):
                mid = 0.5 * (lo + hi)
                fm = _event_value(kind, mid, h, p, gc, gt, gd0, gd1, kt, kn, mu, n0, dim,
                                  normal, Tc)
                if (fm > 0.0) == (f0 > 0.0):
                    lo = mid
                else:
                    hi = mid
            first = min(first, 0.5 * (lo + hi))
    return first


@njit(cache=True)
def _commit(h, Fprev, Fend, committed, trial, C, kt, dim, energy, wf, wn):  # pragma: no cover
    """Accept a step: the end state becomes the committed one, and the step's
    energies are added: energy[0] external ``dq . F_avg``, energy[1] viscous
    ``h v_avg' C v_avg``; wf, wn (P,) friction ``T_avg . Dw`` and normal
    ``N_avg Dv`` work."""
    q, v, a, Tc, Nc, Nrc, gc, sc = committed
    a1, qt, vt, dq, Tt, Nt, Nrt, st, gt = trial
    n = q.size
    ext = 0.0
    visc = 0.0
    for i in range(n):
        ext += dq[i] * 0.5 * (Fprev[i] + Fend[i])
        s = 0.0
        for j in range(n):
            s += C[i, j] * 0.5 * (v[j] + vt[j])
        visc += h * 0.5 * (v[i] + vt[i]) * s
    for j in range(n):
        q[j] = qt[j]
        v[j] = vt[j]
        a[j] = a1[j]
    energy[0] += ext
    energy[1] += visc
    for p in range(Tc.shape[0]):
        w = 0.0
        for j in range(dim[p]):
            dw = (gt[p, j] - gc[p, j]) - (Tt[p, j] - Tc[p, j]) / kt[p, j]
            w += 0.5 * (Tt[p, j] + Tc[p, j]) * dw
        wf[p] += w
        wn[p] += 0.5 * (Nt[p] + Nc[p]) * (gt[p, 2] - gc[p, 2])
        Tc[p, 0] = Tt[p, 0]
        Tc[p, 1] = Tt[p, 1]
        Nc[p] = Nt[p]
        Nrc[p] = Nrt[p]
        sc[p] = st[p]
        for j in range(3):
            gc[p, j] = gt[p, j]


@njit(cache=True)
def march(committed, structure, contacts, F, dt, newton, events, history):  # pragma: no cover
    """Advance F.shape[0] - 1 steps of dt in place from the committed state
    (q, v, a, Tc, Nc, Nrc, gc, sc); F: (n + 1, n_dof) load at the step ends,
    linear in between. A step in which a contact changes state is split at the
    transition (at most max_events times per step, not closer than
    min_fraction to either end) so that no kink of the contact force falls
    inside a step. Records the states 0..n and the cumulative energies
    (e_out (n + 1, 2) external and viscous, wf_out, wn_out (n + 1, P)).
    Returns (Newton iterations, sub-steps added, index of a failed step or -1).
    newton: (rtol, max_iter); events: (max_events, min_fraction)."""
    q, v, a, Tc, Nc, Nrc, gc, sc = committed
    C = structure[1]
    B, row0, dim, kt = contacts[0], contacts[1], contacts[2], contacts[4]
    max_events, min_fraction = events
    q_out, v_out, T_out, N_out, s_out, g_out, e_out, wf_out, wn_out = history
    n = q.size
    P = row0.size
    R = B.shape[0]
    steps = F.shape[0] - 1
    a1 = np.empty(n)
    qt = np.empty(n)
    vt = np.empty(n)
    dq = np.empty(n)
    work = np.empty((3, n))
    J = np.empty((n, n))
    Tt = np.empty((P, 2))
    Nt = np.empty(P)
    Nrt = np.empty(P)
    st = np.empty(P, dtype=np.int8)
    gt = np.empty((P, 3))
    gq = np.empty(R)
    gd0 = np.empty((P, 3))
    gd1 = np.empty((P, 3))
    Dp = np.empty((3, 3))
    tmp = np.empty(2)
    Fs = np.empty(n)
    Fe = np.empty(n)
    trial = (a1, qt, vt, dq, Tt, Nt, Nrt, st, gt)
    scratch = (work, J, gq, Dp, tmp)
    energy = np.zeros(2)
    wf = np.zeros(P)
    wn = np.zeros(P)
    total = 0
    added = 0
    for k in range(steps + 1):
        if k > 0:
            pos = 0.0  # fraction of the grid step done
            splits = 0
            for j in range(n):
                Fs[j] = F[k - 1, j]
            while True:
                h = (1.0 - pos) * dt
                its, ok = _solve_step(h, F[k], committed, structure, contacts, newton, trial,
                                      scratch)
                total += its
                if not ok:
                    return total, added, k
                s = 2.0
                if splits < max_events:
                    s = _first_event(h, committed, contacts, trial, gd0, gd1, gq)
                if min_fraction < s < 1.0 - min_fraction:
                    frac = pos + s * (1.0 - pos)
                    for j in range(n):
                        Fe[j] = F[k - 1, j] + frac * (F[k, j] - F[k - 1, j])
                    its, ok = _solve_step(s * h, Fe, committed, structure, contacts, newton,
                                          trial, scratch)
                    total += its
                    if not ok:
                        return total, added, k
                    _commit(s * h, Fs, Fe, committed, trial, C, kt, dim, energy, wf, wn)
                    for j in range(n):
                        Fs[j] = Fe[j]
                    pos = frac
                    splits += 1
                    added += 1
                    continue
                _commit(h, Fs, F[k], committed, trial, C, kt, dim, energy, wf, wn)
                break
        q_out[k] = q
        v_out[k] = v
        T_out[k] = Tc
        N_out[k] = Nc
        s_out[k] = sc
        g_out[k] = gc
        e_out[k] = energy
        wf_out[k] = wf
        wn_out[k] = wn
    return total, added, -1
