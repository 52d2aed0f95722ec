"""The periodic cycle of one point: plain periods, shooting on the periodicity, the corner
of a 2D stuck set, shakedown (stuck after slipping); and the derivatives of a cycle with
no sample that erases its memory."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..states import SAMPLE_OPEN, SAMPLE_SLIP, SAMPLE_STICK
from .steps import STICK_SLACK, march_period

SHOOT_AFTER = 4  # plain periods before Newton on the cycle's periodicity
SINGULAR = 1e-8  # smallest singular value of (I - Phi) below which a cycle is not isolated
TOUCH = 1e-9  # return-map corrections below this (x the force scale) only touch the limit
PLAIN, SHOT, CORNER = 0, 1, 2  # how periodic_cycle reached the cycle


@njit(cache=True)
def periodic_cycle(p, motion, law, E, has_normal, want_jac, max_periods, rtol, state,
                   samples):  # pragma: no cover
    """March whole periods from the start convention until the force at the end
    of a period repeats (rtol > 0), or exactly ``max_periods`` (rtol = 0).

    A cycle still drifting after SHOOT_AFTER periods (2D partial slip contracts
    slowly) is found by Newton on periodicity, ``T_s += (I - Phi)^-1 (P(T_s) -
    T_s)`` with Phi = dP/dT_s carried through each period. That is sound for an
    isolated cycle. A cycle that sticks all period, or only touches the limit,
    is one of a continuum of periodic cycles (shifted stuck cycles, Phi = I),
    and which one holds is the history's choice: the predictor/corrector of
    Firrone & Zucca eqs. 26-28, the march from ``T = kt u``. A Newton jump into that
    continuum lands on one of them by chance (and its derivative would need
    that of Phi). Two cases are told apart:

    * the march was closing in on a corner of the stuck set, slipping at the
      same two samples a and b period after period (alternate projections onto
      two limit circles, contracting by a factor set by their angle, slowly
      when it is small): its limit is the stuck cycle touching the limit at
      both, found in closed form (:func:`_corner_point`);
    * otherwise the cycle is marched again without jumps (a cycle touching the
      limit at one sample is reached in finitely many periods, a few tens in
      the cases met).

    In 2D the plain march is first watched for CORNER_PERIODS periods
    (:func:`_plain_corner`): a march that keeps slipping at the same few samples is
    closing in on a corner of the stuck set, the one its own state approaches (a
    Newton jump lands near another corner by chance, and which one it was changed
    from one input to the next: the forces jumped by a percent).

    Returns the periods, how the cycle was reached (PLAIN: by the march alone,
    replayable with derivatives; SHOT: an isolated cycle, by jumps; CORNER) and
    the corner's samples a, b (-1 unless CORNER). The arguments: as
    :func:`~.steps.march_period`'s."""
    u, v = motion
    kt, kn, mu, n0 = law
    T, Tp, dT, G = state
    T_out, N_out, state_out = samples
    d, ns = u.shape[1], u.shape[2]
    shooting = rtol > 0.0 and not want_jac
    if d == 2 and shooting:
        periods, a, b = _plain_corner(p, motion, law, E, has_normal, rtol, state, samples)
        if a >= 0:
            return periods, CORNER, a, b
        if a == -2:  # the plain march settled by itself
            return periods, PLAIN, -1, -1
    periods, jumped, isolated, a, b = _periods(p, motion, law, E, has_normal, want_jac,
                                               max_periods, rtol, shooting, state, samples)
    if not jumped:
        return periods, PLAIN, -1, -1
    if isolated:
        return periods, SHOT, -1, -1
    if d == 2 and a >= 0 and _corner_start(p, a, b, u, v, kt, kn, mu, n0, T_out, T):
        no = np.bool_(False)
        march_period(p, np.int64(0), ns, no, motion, law, E, has_normal,
                     no, no, state, samples, np.int64(-1), no)
        stuck = True
        for k in range(ns):
            if state_out[p, k] != SAMPLE_STICK:
                stuck = False
        if stuck:
            return periods + 1, CORNER, a, b
    periods, _, _, _, _ = _periods(p, motion, law, E, has_normal, want_jac, max_periods, rtol,
                                   np.bool_(False), state, samples)
    return periods, PLAIN, -1, -1


CORNER_PERIODS = 10  # plain periods watched for a corner of the stuck set (2D)
CORNER_SAMPLES = 4  # at most this many slipping samples per period to try pairs of


@njit(cache=True)
def _plain_corner(p, motion, law, E, has_normal, rtol, state, samples):  # pragma: no cover
    """The plain march (no jumps, from the start convention) for up to CORNER_PERIODS
    periods, watched for a corner of the stuck set from period SHOOT_AFTER + 1 on: the same
    2..CORNER_SAMPLES samples slipping in two periods running, the contact closed all
    period. The corner is then
    the crossing of two of their limit circles that satisfies every sample's limit (the
    stuck cycle ``T = c + kt u`` through it), the feasible one nearest the march's own
    state; it is marched one period to confirm it sticks everywhere.

    Returns (periods, a, b): the corner's samples; a = -2 if the march settled by itself
    (the outputs then hold its last period, as _periods leaves them); a = -1 if neither
    (the caller starts over)."""
    u, v = motion
    kt, kn, mu, n0 = law
    T, Tp, dT, G = state
    T_out, N_out, state_out = samples
    d, ns = u.shape[1], u.shape[2]
    no = np.bool_(False)
    closed = n0[p] + kn[p] * v[p, ns - 1] > 0.0
    for j in range(d):
        T[j] = kt[p, j] * u[p, j, ns - 1] if closed else 0.0
    Tend = T.copy()
    last = np.full(CORNER_SAMPLES, -1)
    slips = np.full(CORNER_SAMPLES, -1)
    for period in range(CORNER_PERIODS):
        was_open = not closed if period == 0 else state_out[p, ns - 1] == SAMPLE_OPEN
        slipped = period > 0 and state_out[p, ns - 1] == SAMPLE_SLIP
        scale = march_period(p, np.int64(0), ns, was_open, motion, law, E, has_normal,
                             no, no, state, samples, np.int64(-1), slipped)
        diff = 0.0
        for j in range(d):
            diff = max(diff, abs(T[j] - Tend[j]))
        if diff <= rtol * scale or scale == 0.0:
            return period + 1, -2, -2
        for j in range(d):
            Tend[j] = T[j]
        count = 0
        opened = False
        slips[:] = -1
        for k in range(ns):
            if state_out[p, k] == SAMPLE_OPEN:
                opened = True
            elif state_out[p, k] == SAMPLE_SLIP:
                if count < CORNER_SAMPLES:
                    slips[count] = k
                count += 1
        same = 2 <= count <= CORNER_SAMPLES and not opened
        for i in range(CORNER_SAMPLES):
            same = same and slips[i] == last[i]
        last[:] = slips
        if not same or period < SHOOT_AFTER:  # a march settling within a few periods stays
            continue                            # plain (replayed as it is, to the bit)
        # the feasible crossing nearest the march's state c = T - kt u (end of period)
        c0 = T_out[p, 0, ns - 1] - kt[p, 0] * u[p, 0, ns - 1]
        c1 = T_out[p, 1, ns - 1] - kt[p, 1] * u[p, 1, ns - 1]
        best, ba, bb, bc0, bc1 = np.inf, -1, -1, 0.0, 0.0
        for i in range(count):
            for k in range(i + 1, count):
                ok, x0, x1 = _corner_point(p, slips[i], slips[k], u, v, kt, kn, mu, n0, c0,
                                           c1)
                if not ok or not _stuck_everywhere(p, x0, x1, u, v, kt, kn, mu, n0):
                    continue
                dist = (x0 - c0) ** 2 + (x1 - c1) ** 2
                if dist < best:
                    best, ba, bb, bc0, bc1 = dist, slips[i], slips[k], x0, x1
        if ba < 0:
            continue
        T[0] = bc0 + kt[p, 0] * u[p, 0, ns - 1]
        T[1] = bc1 + kt[p, 1] * u[p, 1, ns - 1]
        march_period(p, np.int64(0), ns, no, motion, law, E, has_normal,
                     no, no, state, samples, np.int64(-1), no)
        for k in range(ns):
            if state_out[p, k] != SAMPLE_STICK:
                return period + 2, -1, -1
        return period + 2, ba, bb
    return CORNER_PERIODS, -1, -1


@njit(cache=True)
def _stuck_everywhere(p, c0, c1, u, v, kt, kn, mu, n0):  # pragma: no cover
    """Whether the stuck cycle T = c + kt u is within every sample's limit (to the stick
    slack) with the contact closed all period."""
    ns = u.shape[2]
    for k in range(ns):
        N = n0[p] + kn[p] * v[p, k]
        if N <= 0.0:
            return False
        t0 = c0 + kt[p, 0] * u[p, 0, k]
        t1 = c1 + kt[p, 1] * u[p, 1, k]
        lim = mu[p] * N
        slack = lim + kt[p, 0] * abs(u[p, 0, k]) + kt[p, 1] * abs(u[p, 1, k])
        if np.sqrt(t0 * t0 + t1 * t1) > lim + 1e3 * STICK_SLACK * slack:
            return False
    return True


@njit(cache=True)
def _periods(p, motion, law, E, has_normal, want_jac, max_periods, rtol, shooting, state,
             samples):  # pragma: no cover
    """The march of :func:`periodic_cycle`, with Newton jumps after SHOOT_AFTER periods
    if ``shooting``. Returns the periods; whether the last period started from
    a jump; if so, whether the cycle is isolated (:func:`_isolated`); and the
    two slip samples a, b of the last periods that slipped if they were the
    same in the last two of them (-1 otherwise)."""
    u, v = motion
    kt, kn, mu, n0 = law
    T, Tp, dT, G = state
    T_out, N_out, state_out = samples
    d, ns = u.shape[1], u.shape[2]
    nc = E.shape[1]
    m = (d + int(has_normal)) * nc + 1  # derivative columns (dT may be a placeholder)
    # start: previous sample at k = ns - 1 with T = kt u (Firrone & Zucca eq. 26), or open
    closed = n0[p] + kn[p] * v[p, ns - 1] > 0.0
    if want_jac:
        dT[:, :] = 0.0
    for j in range(d):
        T[j] = kt[p, j] * u[p, j, ns - 1] if closed else 0.0
        if want_jac and closed:
            for c in range(nc):
                dT[j, j * nc + c] = kt[p, j] * E[ns - 1, c]
    Tend = T.copy()
    shoot = np.zeros((d, m + d))
    periods = 0
    jumped = from_jump = newton = stable = False
    a = b = -1
    for period in range(max_periods):
        periods = period + 1
        from_jump = jumped
        was_open = not closed if period == 0 else state_out[p, ns - 1] == SAMPLE_OPEN
        newton = shooting and period >= SHOOT_AFTER
        slipped = period > 0 and state_out[p, ns - 1] == SAMPLE_SLIP
        if newton:
            shoot[:, :] = 0.0
            for j in range(d):
                shoot[j, m + j] = 1.0
            scale = march_period(p, np.int64(0), ns, was_open, motion, law, E, has_normal,
                                 np.bool_(True), np.bool_(False), (T, Tp, shoot, G), samples,
                                 m - 1, slipped)
        else:
            scale = march_period(p, np.int64(0), ns, was_open, motion, law, E, has_normal,
                                 want_jac, want_jac, state, samples, np.int64(-1), slipped)
        if shooting and period >= SHOOT_AFTER - 1:
            # the slip samples, when two (a corner of the stuck set being closed in on)
            count, i0, i1 = 0, -1, -1
            for k in range(ns):
                if state_out[p, k] == SAMPLE_SLIP:
                    count += 1
                    if count == 1:
                        i0 = k
                    elif count == 2:
                        i1 = k
            if count == 2:
                stable = i0 == a and i1 == b
                a, b = i0, i1
            elif count > 0:
                a = b = -1
                stable = False
        diff = 0.0
        for j in range(d):
            diff = max(diff, abs(T[j] - Tend[j]))
        if rtol > 0.0 and (diff <= rtol * scale or scale == 0.0):
            break
        if newton:
            # T_end = P(T_start): solve (I - Phi) dT_s = P(T_s) - T_s for the next start
            a00 = 1.0 - shoot[0, m]
            r0 = T[0] - Tend[0]
            if d == 1:
                if a00 != 0.0:
                    T[0] = Tend[0] + r0 / a00
                    jumped = True
            else:
                a01, a10, a11 = -shoot[0, m + 1], -shoot[1, m], 1.0 - shoot[1, m + 1]
                r1 = T[1] - Tend[1]
                det = a00 * a11 - a01 * a10
                if det != 0.0:
                    T[0] = Tend[0] + (a11 * r0 - a01 * r1) / det
                    T[1] = Tend[1] + (a00 * r1 - a10 * r0) / det
                    jumped = True
        for j in range(d):
            Tend[j] = T[j]
    if not stable:
        a = b = -1
    if not from_jump:
        return periods, False, False, a, b
    # jumps leave every later period in Newton mode: shoot holds the last one's Phi
    return periods, True, _isolated(p, shoot, m, u, kt, mu, T_out, N_out, state_out), a, b


@njit(cache=True)
def _isolated(p, ext, m, u, kt, mu, T_out, N_out, state_out):  # pragma: no cover
    """Whether the period last marched (in the outputs; ext[:, m:] its Phi =
    dT_end / dT_start) is an isolated periodic cycle, whose start state the
    periodicity fixes.

    Isolated: it opens (the memory is erased), or it slips with (I - Phi)
    regular. Not: it sticks all period (Phi = I), or it only touches the limit
    (every return-map correction ``|Tp - T|`` below TOUCH x the force scale:
    rounding, or the drift the periodicity test lets through, 1e-13 by
    default), or (I - Phi) has a smallest singular value below SINGULAR
    (estimated as |det| / Frobenius norm, within a factor sqrt 2; a cycle
    contracting that slowly is not told from a stuck one in 1e8 periods). A
    slip cycle has corrections that balance over the period, each set by the
    motion, and (I - Phi) set by the directions of its slip arcs."""
    d, ns = T_out.shape[1], T_out.shape[2]
    scale = 0.0
    jump = 0.0
    for k in range(ns):
        if state_out[p, k] == SAMPLE_OPEN:
            return True
        kprev = k - 1 if k > 0 else ns - 1
        scale = max(scale, mu[p] * N_out[p, k])
        corr = 0.0
        for j in range(d):
            scale = max(scale, abs(T_out[p, j, k]))
            if state_out[p, k] == SAMPLE_SLIP:
                tp = T_out[p, j, kprev] + kt[p, j] * (u[p, j, k] - u[p, j, kprev])
                corr += (tp - T_out[p, j, k]) ** 2
        jump = max(jump, np.sqrt(corr))
    if jump <= TOUCH * scale:
        return False
    if d == 1:
        return abs(1.0 - ext[0, m]) > SINGULAR
    a00, a01 = 1.0 - ext[0, m], -ext[0, m + 1]
    a10, a11 = -ext[1, m], 1.0 - ext[1, m + 1]
    det = a00 * a11 - a01 * a10
    fro = np.sqrt(a00 * a00 + a01 * a01 + a10 * a10 + a11 * a11)
    return abs(det) > SINGULAR * fro


@njit(cache=True)
def _corner_start(p, a, b, u, v, kt, kn, mu, n0, T_out, T):  # pragma: no cover
    """Start state (into T) of the 2D stuck cycle ``T_k = c + kt u_k`` that
    touches the limit at samples a and b, ``|c + kt u_i| = mu N_i``: the
    intersection of two circles in c, the one nearest the cycle in the
    outputs. False if the circles do not cross at an angle (sine) above
    SINGULAR."""
    ns = T_out.shape[2]
    c0 = T_out[p, 0, ns - 1] - kt[p, 0] * u[p, 0, ns - 1]
    c1 = T_out[p, 1, ns - 1] - kt[p, 1] * u[p, 1, ns - 1]
    ok, c0, c1 = _corner_point(p, a, b, u, v, kt, kn, mu, n0, c0, c1)
    if ok:
        T[0] = c0 + kt[p, 0] * u[p, 0, ns - 1]
        T[1] = c1 + kt[p, 1] * u[p, 1, ns - 1]
    return ok


@njit(cache=True)
def _corner_point(p, a, b, u, v, kt, kn, mu, n0, c0, c1):  # pragma: no cover
    """The point c nearest (c0, c1) with ``|c + kt u_i| = mu N_i`` at i = a, b:
    (ok, c). Circles about -kt u_i; c = P_a + x e +- h e_perp."""
    ra = mu[p] * (n0[p] + kn[p] * v[p, a])
    rb = mu[p] * (n0[p] + kn[p] * v[p, b])
    pa0, pa1 = -kt[p, 0] * u[p, 0, a], -kt[p, 1] * u[p, 1, a]
    dx0, dx1 = -kt[p, 0] * u[p, 0, b] - pa0, -kt[p, 1] * u[p, 1, b] - pa1
    dist = np.sqrt(dx0 * dx0 + dx1 * dx1)
    if ra <= 0.0 or rb <= 0.0 or dist == 0.0:
        return False, c0, c1
    e0, e1 = dx0 / dist, dx1 / dist
    x = (dist * dist + ra * ra - rb * rb) / (2.0 * dist)
    h2 = ra * ra - x * x
    # sine of the angle between the circles' normals at c: dist h / (ra rb)
    if h2 <= 0.0 or dist * np.sqrt(h2) <= SINGULAR * ra * rb:
        return False, c0, c1
    h = np.sqrt(h2)
    if (c0 - pa0 - x * e0) * -e1 + (c1 - pa1 - x * e1) * e0 < 0.0:
        h = -h
    return True, pa0 + x * e0 - h * e1, pa1 + x * e1 + h * e0


@njit(cache=True)
def corner_derivative(p, a, b, motion, law, E, has_normal, state, samples):  # pragma: no cover
    """Derivatives of the stuck cycle on a corner (:func:`periodic_cycle`): c by
    implicit differentiation of the touching conditions ``|w_i| = mu N_i``,
    ``w_i = c + kt u_i`` (i = a, b), ``n_i . (dc + kt du_i) = mu dN_i`` with
    n_i = w_i / |w_i|, then the period from ``T_s = c + kt u_{N-1}`` storing G.
    That is the derivative of the corner the forces are on (exact)."""
    u, v = motion
    kt, kn, mu, n0 = law
    T, Tp, dT, G = state
    T_out, N_out, state_out = samples
    ns = u.shape[2]
    nc = E.shape[1]
    m = dT.shape[1]
    vcol = 2 * nc
    c0 = T_out[p, 0, ns - 1] - kt[p, 0] * u[p, 0, ns - 1]
    c1 = T_out[p, 1, ns - 1] - kt[p, 1] * u[p, 1, ns - 1]
    _, c0, c1 = _corner_point(p, a, b, u, v, kt, kn, mu, n0, c0, c1)
    la = mu[p] * (n0[p] + kn[p] * v[p, a])
    lb = mu[p] * (n0[p] + kn[p] * v[p, b])
    na0, na1 = (c0 + kt[p, 0] * u[p, 0, a]) / la, (c1 + kt[p, 1] * u[p, 1, a]) / la
    nb0, nb1 = (c0 + kt[p, 0] * u[p, 0, b]) / lb, (c1 + kt[p, 1] * u[p, 1, b]) / lb
    det = na0 * nb1 - na1 * nb0
    for col in range(m):
        ra = rb = 0.0  # mu dN_i - n_i . kt du_i
        if col < nc:
            ra = -na0 * kt[p, 0] * E[a, col]
            rb = -nb0 * kt[p, 0] * E[b, col]
        elif col < 2 * nc:
            ra = -na1 * kt[p, 1] * E[a, col - nc]
            rb = -nb1 * kt[p, 1] * E[b, col - nc]
        elif has_normal and col < vcol + nc:
            ra = mu[p] * kn[p] * E[a, col - vcol]
            rb = mu[p] * kn[p] * E[b, col - vcol]
        elif col == m - 1:
            ra = rb = mu[p]
        dT[0, col] = (nb1 * ra - na1 * rb) / det
        dT[1, col] = (na0 * rb - nb0 * ra) / det
    for c in range(nc):  # T_s = c + kt u_{N-1}
        dT[0, c] += kt[p, 0] * E[ns - 1, c]
        dT[1, nc + c] += kt[p, 1] * E[ns - 1, c]
    T[0] = c0 + kt[p, 0] * u[p, 0, ns - 1]
    T[1] = c1 + kt[p, 1] * u[p, 1, ns - 1]
    yes, no = np.bool_(True), np.bool_(False)
    march_period(p, np.int64(0), ns, no, motion, law, E, has_normal,
                 yes, yes, state, samples, np.int64(-1), no)


@njit(cache=True)
def periodic_derivative(p, motion, law, E, has_normal, replayable, state,
                        samples):  # pragma: no cover
    """Derivatives of a slowly contracting cycle with no memory-erasing sample:
    one period from the periodic state with d extra columns for the start
    state gives b and Phi in dT_end = Phi dT_start + b; the periodic orbit has
    dT_start = (I - Phi)^-1 b; a second period stores G from it. Two periods
    instead of re-marching all of them.

    A cycle that is not isolated (:func:`_isolated`: stuck all period, where
    Phi = I and b = 0, or touching the limit) satisfies that equation for any
    dT_start, or hardly depends on it: its start state is the march's choice
    and its derivative that of the march. Then nothing is stored and False is
    returned, for the caller to march again with derivatives; that needs the
    cycle ``replayable``, reached without Newton jumps, which :func:`periodic_cycle`
    ensures for every cycle that is not isolated (a cycle reached by jumps is
    solved here whatever this period shows)."""
    u, v = motion
    kt, kn, mu, n0 = law
    T, Tp, dT, G = state
    T_out, N_out, state_out = samples
    d, ns = u.shape[1], u.shape[2]
    m = dT.shape[1]
    if replayable:
        slips = False
        for k in range(ns):
            if state_out[p, k] == SAMPLE_SLIP:
                slips = True
                break
        if not slips:
            return False  # stuck all period: Phi = I, b = 0
    ext = np.zeros((d, m + d))
    T0 = np.empty(d)
    for j in range(d):
        T0[j] = T_out[p, j, ns - 1]
        T[j] = T0[j]
        ext[j, m + j] = 1.0
    last_slip = state_out[p, ns - 1] == SAMPLE_SLIP
    k0, yes, no = np.int64(0), np.bool_(True), np.bool_(False)
    march_period(p, k0, ns, no, motion, law, E, has_normal,
                 yes, no, (T, Tp, ext, G), samples, m - 1, last_slip)
    if replayable and not _isolated(p, ext, m, u, kt, mu, T_out, N_out, state_out):
        return False
    # (I - Phi) dT_start = b with Phi = ext[:, m:], b = ext[:, :m], in scalars: array
    # arithmetic would compile numba's shape-mismatch errors (string formatting, ~3 s)
    a00 = 1.0 - ext[0, m]
    if d == 1:
        for col in range(m):
            dT[0, col] = ext[0, col] / a00
    else:
        a01, a10, a11 = -ext[0, m + 1], -ext[1, m], 1.0 - ext[1, m + 1]
        det = a00 * a11 - a01 * a10
        for col in range(m):
            dT[0, col] = (a11 * ext[0, col] - a01 * ext[1, col]) / det
            dT[1, col] = (a00 * ext[1, col] - a10 * ext[0, col]) / det
    for j in range(d):
        T[j] = T0[j]
    march_period(p, k0, ns, no, motion, law, E, has_normal,
                 yes, yes, state, samples, np.int64(-1), last_slip)
    return True


@njit(cache=True)
def erased(p, e, kn, mu, E, has_normal, T_out, N_out, state_out, T, dT):  # pragma: no cover
    """State and derivative at a sample that erases the march's memory: open
    (T = 0) or 1D slip (T = mu N sign, dT = mu sign dN)."""
    d = T.size
    nc = E.shape[1]
    m = dT.shape[1]
    dT[:, :] = 0.0
    for j in range(d):
        T[j] = T_out[p, j, e]
    if state_out[p, e] == SAMPLE_OPEN:
        return
    sgn = 1.0 if T[0] > 0.0 else -1.0
    if has_normal:
        for c in range(nc):
            dT[0, d * nc + c] = sgn * mu[p] * kn[p] * E[e, c]
    dT[0, m - 1] = sgn * mu[p]
