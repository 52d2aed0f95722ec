"""Compiled hot loop: the friction return map marched over sampled periods.

One kernel serves the four contact laws of :mod:`.laws`: the tangential
dimension ``d`` is 1 or 2 and a constant normal load is ``kn = 0``. For each
point, given time samples of the tangential relative displacement ``u`` (d
components) and of the normal one ``v``, the normal force is
``N_k = max(n0 + kn v_k, 0)`` and the tangential force follows

    predictor   Tp = T_{k-1} + kt * (u_k - u_{k-1})
    open        N_k = 0           ->  T_k = 0
    stick       |Tp| <= mu N_k    ->  T_k = Tp   (to rounding: STICK_SLACK)
    slip        otherwise         ->  T_k = mu N_k Tp / |Tp|   (radial return)

In 2D a slip that continues from a slipping sample is integrated exactly over
the step instead (:func:`_slip_flow`: the force direction relaxes towards the
predictor's increment, tan(a/2) ~ exp(-kt |du| int ds / mu N)); radial return,
its backward-Euler step, is first order in the sample spacing, the exact flow
second order (measured on the circle's closed form: 1.1e-3, 6.7e-5, 4.2e-6 at
64, 256, 1024 samples).

The march starts as if the previous sample had ``T = kt u_{N-1}``, so the
first predictor is ``kt u_0`` (the static part included: seed eqs. 26-28), and
repeats periods until the force at the end of a period repeats. A cycle that
sticks all period is periodic from any nearby start (it is not unique, and
the periodicity leaves its derivative free: Phi = I): the one returned is
where that march settles, slipping in its first periods if it must
("shakedown"), and its derivatives are those of the same march, repeated
with derivatives. When the march closes in on a corner of the stuck set
(slipping at the same two samples period after period, contracting slowly)
the cycle is the one touching the limit at both, in closed form and
differentiated implicitly (:func:`_cycle`).

Sub-sample transitions. Between two samples the inputs are taken linear in
time. A contact that closes inside an interval starts sticking from where it
closed, ``Tp = kt (u_k - u(s_z))``, not from the previous sample. The Fourier
projection is the trapezoid rule, spectrally accurate on the smooth stretches
of T and N but only O(h^2) across a kink (stick->slip, opening, closing). Each
kink, located at fraction ``s`` of its interval, with slope jump J taken from
the exact slopes of the trigonometric inputs there, gets the Euler-Maclaurin
term of the periodic trapezoid rule removed, ``h^2 J (s (1 - s) - 1/6) / 2``.
That makes the error O(h^3) and, as importantly for Newton, keeps the
coefficients continuous as a transition moves from one interval to the next.

Derivatives are propagated forward through the same recursion (Petrov & Ewins
2003): ``G_k = dT_k / d(inputs)``, the inputs being the Fourier coefficients
of every component and ``n0``. The last period's ``G`` is projected onto the
harmonics with one matrix product per point; the kink terms are differentiated
in closed form.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numba
import numpy as np
from numba import njit, prange, types

from .states import SAMPLE_OPEN, SAMPLE_SLIP, SAMPLE_STICK

# A predictor this close to the limit, relative to the magnitudes it is computed from
# (mu N and kt |u|), sticks. A cycle stuck after slipping ("shakedown") touches the limit
# where it last slipped and comes back there each period with the rounding of a period's
# increments (~1e-15 of those magnitudes, measured to 4096 samples; at most ns * 1.1e-16,
# 5e-13): stick or slip decided by those bits would switch the sub-sample kink term on and
# off (an O(h^3) step in the forces), so the forces would not be differentiable there.
STICK_SLACK = 1e-11


# numba compiles a kernel and every helper once per argument types, so march casts its
# inputs to one type each, and constants passed between the helpers are wrapped
# (np.int64(0), np.bool_(True)): a bare literal types as Literal[...] and compiles the
# callee once more per value (_steps was compiled 16 times). (dtype, ndim) per argument of
# march; ndim 0 is a scalar.
_ARGS = ((np.float64, 3), (np.float64, 3), (np.float64, 2), (np.float64, 2), (np.float64, 1),
         (np.float64, 1), (np.float64, 1), (np.float64, 2), (np.float64, 2), (np.float64, 1),
         (np.int8, 1), (np.bool_, 0), (np.bool_, 0), (np.int64, 0), (np.float64, 0),
         (np.bool_, 0), (np.float64, 3), (np.float64, 2), (np.int8, 2), (np.float64, 3),
         (np.float64, 4), (np.float64, 3), (np.int64, 1), (np.int64, 2))
_OUTPUTS = frozenset((1, 2, *range(16, 24)))  # written in place: checked, never copied
_KINDS = tuple((np.dtype(dt), nd) for dt, nd in _ARGS)
_SCALAR = {np.dtype(np.bool_): bool, np.dtype(np.int64): int, np.dtype(np.float64): float}
SIGNATURE = tuple(numba.from_dtype(dt) if nd == 0 else types.Array(numba.from_dtype(dt), nd, "C")
                  for dt, nd in _KINDS)

# Work (points x samples x derivative columns) from which march shares the points among
# threads: a serial march costs ~23 ns per unit (laws A and D). Median ms, serial vs 2
# threads, law A (H = 1, 128 samples, 4 columns; work = 512 P): quiet cores, P = 1: 0.045 vs
# 0.053, 4: 0.077 vs 0.073, 64: 0.73 vs 0.40, 1024: 11.9 vs 6.2; under load 3-4 with
# OpenMP, P = 1: 0.045 vs 0.047 (p90 7.9: a descheduled thread stalls the join a time
# slice), 16: 0.20 vs 6.2, 256: 3.8 vs 11, 1024: 12 vs 16, 2048: 23 vs 24 (TBB: 0.96-1.04x
# at every P); law D (H = 3, 64 samples, 22 columns), loaded: P = 64: 1.9 vs 8.0, 256: 8.2
# vs 8.0. From ~12 ms a stall costs little and threads halve the time on quiet cores.
PARALLEL_MIN_WORK = 2**19
# Compile time of the serial kernel, s, told on a first run (measured 10.9 s, quiet cores).
COMPILE_SECONDS = 10


def march(*args: object) -> None:
    """March the return map of every point to its periodic steady state.

    args: g, u, v, kt, kn, mu, n0, E, A, corder, ckind, has_normal, want_jac,
    max_periods, rtol, corrections, T_out, N_out, state_out, F_out, J_out, D_out,
    periods_out, counts_out; the points run serially or on threads
    (:func:`parallel_pays`), with the same results.

    g: (P, d + has_normal, nc) input coefficients; u: (P, d, ns) and v: (P, ns)
    receive the tangential and normal samples (the synthesis of g; v = 0 for
    the constant-load laws);
    kt: (P, d); kn, mu, n0: (P,); E: (ns, nc) synthesis; A: (nc, ns) analysis;
    corder (nc,) float harmonic order and ckind (nc,) int (0 constant, 1 cos,
    2 sin) of each coefficient.
    Outputs: T_out (P, d, ns), N_out (P, ns), state_out (P, ns) int8,
    F_out (P, d + 1, nc) force coefficients [T_1, ..., T_d, N],
    J_out (P, d + has_normal, nc, m - 1) their derivatives by the inputs' coefficients
    [u_1 coeffs, ..., u_d coeffs, (v coeffs)] and D_out (P, d + has_normal, nc) by
    n0 (internally column m - 1, m = (d + has_normal) nc + 1); periods_out (P,).

    The cycle is found without derivatives. Derivatives then take one more
    period from a sample that erases the memory of the march (open, or
    slipping in 1D), where they are exact with no history. A point with no such
    sample either slips on an isolated 2D cycle, whose derivative is that of
    the periodic orbit (:func:`_periodic_derivative`), or sticks all period
    (possibly touching the limit): then its start state, and so every force,
    is what the march from the start convention left (seed eqs. 26-28), and
    the march is repeated with derivatives from the start (as is any march of
    at most two periods), or it sits on a corner of the stuck set
    (:func:`_corner_derivative`).
    """
    args = _cast(args)
    P, ns = args[1].shape[0], args[1].shape[2]
    columns = args[20].shape[3] + 1 if args[12] else 1  # derivative columns carried, J_out
    kernel = _march_parallel if parallel_pays(P, ns, columns) else _march_serial
    kernel(*args)


def parallel_pays(points: int, samples: int, columns: int = 1) -> bool:
    """Whether march runs the points on threads: the work, points x samples x columns
    (the derivative columns carried per sample, 1 without), from PARALLEL_MIN_WORK."""
    return (points > 1 and points * samples * columns >= PARALLEL_MIN_WORK
            and numba.get_num_threads() > 1)


def _cast(args: tuple) -> tuple:
    """The arguments as SIGNATURE types: inputs converted to C-contiguous writeable arrays
    of its dtypes (a copy only when needed), outputs checked (they are written in place).
    Cheap when nothing needs converting (~2 us: march runs thousands of times a curve)."""
    out = list(args)
    for i, (dt, nd) in enumerate(_KINDS):
        a = args[i]
        if nd == 0:
            out[i] = _SCALAR[dt](a)
            continue
        if type(a) is not np.ndarray:
            a = np.asarray(a)
        flags = a.flags
        if a.dtype == dt and a.ndim == nd and flags.c_contiguous and flags.writeable:
            continue
        if i in _OUTPUTS:
            raise ValueError(f"march: output {i} must be a writeable C-contiguous {nd}-d "
                             f"{dt.name} array, got {a.dtype} {a.shape}")
        out[i] = np.array(a, dtype=dt, order="C")  # a writeable copy
    return tuple(out)


def kernels_cached() -> bool:
    """Whether the serial contact kernel is compiled in this process or in numba's on-disk
    cache (NUMBA_CACHE_DIR or __pycache__), so that a first march does not compile it."""
    if SIGNATURE in _march_serial.overloads:
        return True
    try:  # numba's own index of the cache file, without loading the compiled code
        cache = _march_serial._cache
        key = cache._index_key(SIGNATURE, _march_serial.targetctx.codegen())
        return key in cache._cache_file._load_index()
    except Exception:  # a numba without these internals: say nothing rather than guess
        return True


def warm_up(progress: Callable[[str], None] = print) -> None:
    """Compile the serial contact kernel now if it is not cached, telling ``progress``
    (a first run compiles for ~COMPILE_SECONDS; later runs load it from the cache)."""
    if kernels_cached():
        return
    progress(f"compiling the contact kernels (first run only, ~{COMPILE_SECONDS} s) ...")
    t = time.perf_counter()
    _march_serial.compile(SIGNATURE)
    progress(f"compiled the contact kernels in {time.perf_counter() - t:.1f} s")


@njit(cache=True)
def _march_serial(g, u, v, kt, kn, mu, n0, E, A, corder, ckind, has_normal, want_jac,
                  max_periods, rtol, corrections, T_out, N_out, state_out, F_out, J_out, D_out,
                  periods_out, counts_out):  # pragma: no cover
    """march, one point after the other."""
    for p in range(u.shape[0]):
        _point(p, g, u, v, kt, kn, mu, n0, E, A, corder, ckind, has_normal, want_jac,
               max_periods, rtol, corrections, T_out, N_out, state_out, F_out, J_out, D_out,
               periods_out, counts_out)


@njit(cache=True, parallel=True)
def _march_parallel(g, u, v, kt, kn, mu, n0, E, A, corder, ckind, has_normal, want_jac,
                    max_periods, rtol, corrections, T_out, N_out, state_out, F_out, J_out,
                    D_out, periods_out, counts_out):  # pragma: no cover
    """march, the points shared among threads."""
    for i in prange(u.shape[0]):
        # prange's index is unsigned: an int64 point reuses the serial kernel's _point
        _point(np.int64(i), g, u, v, kt, kn, mu, n0, E, A, corder, ckind, has_normal,
               want_jac, max_periods, rtol, corrections, T_out, N_out, state_out, F_out, J_out,
               D_out, periods_out, counts_out)


@njit(inline="always")  # one compiled level less: each re-optimises all it links (~2 s)
def _point(p, g, u, v, kt, kn, mu, n0, E, A, corder, ckind, has_normal, want_jac, max_periods,
           rtol, corrections, T_out, N_out, state_out, F_out, J_out, D_out, periods_out,
           counts_out):  # pragma: no cover
    """march for point p."""
    d, ns = u.shape[1], u.shape[2]
    nc = E.shape[1]
    m = J_out.shape[3] + 1
    yes, no = np.bool_(True), np.bool_(False)
    _synthesis(p, g, E, has_normal, u, v)
    G = np.empty((ns, d * m)) if want_jac else np.empty((1, 1))  # every row written
    dT = np.zeros((d, m))
    T = np.empty(d)
    Tp = np.empty(d)
    periods, how, ca, cb = _cycle(p, u, v, kt, kn, mu, n0, E, has_normal, no, max_periods,
                                  rtol, T, Tp, dT, G, T_out, N_out, state_out)
    if want_jac:
        e = -1
        for k in range(ns):
            if state_out[p, k] == SAMPLE_OPEN or (d == 1 and state_out[p, k] == SAMPLE_SLIP):
                e = k
                break
        if e >= 0:
            _erased(p, e, kn, mu, E, has_normal, T_out, N_out, state_out, T, dT)
            for j in range(d):
                for col in range(m):
                    G[e, j * m + col] = dT[j, col]
            _steps(p, e + 1, ns - 1, state_out[p, e] == SAMPLE_OPEN, u, v, kt, kn, mu, n0, E,
                   has_normal, yes, yes, T, Tp, dT, G, T_out, N_out, state_out, np.int64(-1),
                   state_out[p, e] == SAMPLE_SLIP)
        elif how == CORNER:
            _corner_derivative(p, ca, cb, u, v, kt, kn, mu, n0, E, has_normal, T, Tp, dT,
                               G, T_out, N_out, state_out)
        elif periods <= 2 or not _periodic_derivative(
                p, u, v, kt, kn, mu, n0, E, has_normal, how == PLAIN, T, Tp, dT, G, T_out,
                N_out, state_out):
            # the march again with derivatives from the start convention: short, or a
            # stuck cycle whose start state is the march's choice (seed eqs. 26-28)
            _cycle(p, u, v, kt, kn, mu, n0, E, has_normal, yes, periods, 0.0,
                   T, Tp, dT, G, T_out, N_out, state_out)
    periods_out[p] = periods
    _project(p, d, ns, nc, m, kn, E, A, has_normal, want_jac, T_out, N_out, G,
             F_out, J_out, D_out)
    if corrections:
        _kinks(p, g, kt, kn, mu, n0, u, v, E, corder, ckind, has_normal, want_jac,
               T_out, N_out, state_out, G, F_out, J_out, D_out)
    _count(p, state_out, T_out, counts_out)


@njit(cache=True)
def _synthesis(p, g, E, has_normal, u, v):  # pragma: no cover
    """Time samples of one point's relative displacements from coefficients."""
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


SHOOT_AFTER = 4  # plain periods before Newton on the cycle's periodicity
SINGULAR = 1e-8  # smallest singular value of (I - Phi) below which a cycle is not isolated
TOUCH = 1e-9  # return-map corrections below this (x the force scale) only touch the limit
PLAIN, SHOT, CORNER = 0, 1, 2  # how _cycle reached the cycle


@njit(cache=True)
def _cycle(p, u, v, kt, kn, mu, n0, E, has_normal, want_jac, max_periods, rtol,
           T, Tp, dT, G, T_out, N_out, state_out):  # pragma: no cover
    """March whole periods from the start convention until the force at the end
    of a period repeats (rtol > 0), or exactly ``max_periods`` (rtol = 0).

    A cycle still drifting after SHOOT_AFTER periods (2D partial slip contracts
    slowly) is found by Newton on periodicity, ``T_s += (I - Phi)^-1 (P(T_s) -
    T_s)`` with Phi = dP/dT_s carried through each period. That is sound for an
    isolated cycle. A cycle that sticks all period, or only touches the limit,
    is one of a continuum of periodic cycles (shifted stuck cycles, Phi = I),
    and which one holds is the history's choice: the predictor/corrector of
    seed eqs. 26-28, the march from ``T = kt u``. A Newton jump into that
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
    the corner's samples a, b (-1 unless CORNER)."""
    d, ns = u.shape[1], u.shape[2]
    shooting = rtol > 0.0 and not want_jac
    if d == 2 and shooting:
        periods, a, b = _plain_corner(p, u, v, kt, kn, mu, n0, E, has_normal, rtol, T, Tp,
                                      dT, G, T_out, N_out, state_out)
        if a >= 0:
            return periods, CORNER, a, b
        if a == -2:  # the plain march settled by itself
            return periods, PLAIN, -1, -1
    periods, jumped, isolated, a, b = _periods(p, u, v, kt, kn, mu, n0, E, has_normal, want_jac,
                                               max_periods, rtol, shooting, T, Tp, dT, G,
                                               T_out, N_out, state_out)
    if not jumped:
        return periods, PLAIN, -1, -1
    if isolated:
        return periods, SHOT, -1, -1
    if d == 2 and a >= 0 and _corner_start(p, a, b, u, v, kt, kn, mu, n0, T_out, T):
        no = np.bool_(False)
        _steps(p, np.int64(0), ns, no, u, v, kt, kn, mu, n0, E, has_normal, no, no, T, Tp, dT,
               G, T_out, N_out, state_out, np.int64(-1), no)
        stuck = True
        for k in range(ns):
            if state_out[p, k] != SAMPLE_STICK:
                stuck = False
        if stuck:
            return periods + 1, CORNER, a, b
    periods, _, _, _, _ = _periods(p, u, v, kt, kn, mu, n0, E, has_normal, want_jac,
                                   max_periods, rtol, np.bool_(False), T, Tp, dT, G, T_out,
                                   N_out, state_out)
    return periods, PLAIN, -1, -1


CORNER_PERIODS = 10  # plain periods watched for a corner of the stuck set (2D)
CORNER_SAMPLES = 4  # at most this many slipping samples per period to try pairs of


@njit(cache=True)
def _plain_corner(p, u, v, kt, kn, mu, n0, E, has_normal, rtol, T, Tp, dT, G, T_out, N_out,
                  state_out):  # pragma: no cover
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
        scale = _steps(p, np.int64(0), ns, was_open, u, v, kt, kn, mu, n0, E, has_normal, no,
                       no, T, Tp, dT, G, T_out, N_out, state_out, np.int64(-1), slipped)
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
        _steps(p, np.int64(0), ns, no, u, v, kt, kn, mu, n0, E, has_normal, no, no, T, Tp, dT,
               G, T_out, N_out, state_out, np.int64(-1), no)
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
def _periods(p, u, v, kt, kn, mu, n0, E, has_normal, want_jac, max_periods, rtol, shooting,
             T, Tp, dT, G, T_out, N_out, state_out):  # pragma: no cover
    """The march of :func:`_cycle`, with Newton jumps after SHOOT_AFTER periods
    if ``shooting``. Returns the periods; whether the last period started from
    a jump; if so, whether the cycle is isolated (:func:`_isolated`); and the
    two slip samples a, b of the last periods that slipped if they were the
    same in the last two of them (-1 otherwise)."""
    d, ns = u.shape[1], u.shape[2]
    nc = E.shape[1]
    m = (d + int(has_normal)) * nc + 1  # derivative columns (dT may be a placeholder)
    # start: previous sample at k = ns - 1 with T = kt u (seed eq. 26), or open
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
            scale = _steps(p, np.int64(0), ns, was_open, u, v, kt, kn, mu, n0, E, has_normal,
                           np.bool_(True), np.bool_(False), T, Tp, shoot, G, T_out, N_out,
                           state_out, m - 1, slipped)
        else:
            scale = _steps(p, np.int64(0), ns, was_open, u, v, kt, kn, mu, n0, E, has_normal,
                           want_jac, want_jac, T, Tp, dT, G, T_out, N_out, state_out,
                           np.int64(-1), slipped)
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
def _corner_derivative(p, a, b, u, v, kt, kn, mu, n0, E, has_normal, T, Tp, dT, G, T_out,
                       N_out, state_out):  # pragma: no cover
    """Derivatives of the stuck cycle on a corner (:func:`_cycle`): c by
    implicit differentiation of the touching conditions ``|w_i| = mu N_i``,
    ``w_i = c + kt u_i`` (i = a, b), ``n_i . (dc + kt du_i) = mu dN_i`` with
    n_i = w_i / |w_i|, then the period from ``T_s = c + kt u_{N-1}`` storing G.
    That is the derivative of the corner the forces are on (exact)."""
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
    _steps(p, np.int64(0), ns, no, u, v, kt, kn, mu, n0, E, has_normal, yes, yes, T, Tp, dT, G,
           T_out, N_out, state_out, np.int64(-1), no)


@njit(cache=True)
def _periodic_derivative(p, u, v, kt, kn, mu, n0, E, has_normal, replayable, T, Tp, dT, G,
                         T_out, N_out, state_out):  # pragma: no cover
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
    cycle ``replayable``, reached without Newton jumps, which :func:`_cycle`
    ensures for every cycle that is not isolated (a cycle reached by jumps is
    solved here whatever this period shows)."""
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
    _steps(p, k0, ns, no, u, v, kt, kn, mu, n0, E, has_normal, yes, no, T, Tp, ext,
           G, T_out, N_out, state_out, m - 1, last_slip)
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
    _steps(p, k0, ns, no, u, v, kt, kn, mu, n0, E, has_normal, yes, yes, T, Tp, dT,
           G, T_out, N_out, state_out, np.int64(-1), last_slip)
    return True


@njit(cache=True)
def _erased(p, e, kn, mu, E, has_normal, T_out, N_out, state_out, T, dT):  # pragma: no cover
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


@njit(cache=True)
def _steps(p, k0, count, was_open, u, v, kt, kn, mu, n0, E, has_normal, want_jac, store,
           T, Tp, dT, G, T_out, N_out, state_out, cn0, prev_slip):  # pragma: no cover
    """Advance the return map ``count`` samples from sample k0 (indices taken
    modulo ns), T and dT holding the state at the sample before; with ``store``
    each sample's dT goes to G. Returns the force scale met (max |T| and mu N),
    for the periodicity test. cn0: the n0 column of dT (< 0: its last);
    prev_slip: the sample before slipped (2D slip continues along the exact flow; a slip
    that starts between two stuck-then-slipping samples follows it from the onset)."""
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
            _reclose(p, k, kprev, u, v, kt, kn, n0, E, want_jac, nc, vcol, cn0, Tp, dT)
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
                    p, k, kprev, kt, kn, mu, E, has_normal, want_jac, lim, T, Tp, dT, cn0,
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


@njit(cache=True)
def _project(p, d, ns, nc, m, kn, E, A, has_normal, want_jac, T_out, N_out, G,
             F_out, J_out, D_out):  # pragma: no cover
    """Trapezoid projection of the final period's samples and derivatives."""
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


@njit(cache=True)
def _slip_flow(p, k, kprev, kt, kn, mu, E, has_normal, want_jac, L1, T, Tp, dT,
               cn0, Lp):  # pragma: no cover
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
    to radial return. T and dT (holding dTp on entry) receive the new state."""
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
    a00, a10 = _flow_derivative(1.0, 0.0, 0.0, 0.0, 0.0, t0, t1, L0, L1, h0, h1, nq, c0, p0,
                                p1, np_, Iint, general, Ex, tau0, tau1, den1, C, beta, r0, r1)
    a01, a11 = _flow_derivative(0.0, 1.0, 0.0, 0.0, 0.0, t0, t1, L0, L1, h0, h1, nq, c0, p0,
                                p1, np_, Iint, general, Ex, tau0, tau1, den1, C, beta, r0, r1)
    b00, b10 = _flow_derivative(0.0, 0.0, 1.0, 0.0, 0.0, t0, t1, L0, L1, h0, h1, nq, c0, p0,
                                p1, np_, Iint, general, Ex, tau0, tau1, den1, C, beta, r0, r1)
    b01, b11 = _flow_derivative(0.0, 0.0, 0.0, 1.0, 0.0, t0, t1, L0, L1, h0, h1, nq, c0, p0,
                                p1, np_, Iint, general, Ex, tau0, tau1, den1, C, beta, r0, r1)
    e0, e1 = _flow_derivative(0.0, 0.0, 0.0, 0.0, 1.0, t0, t1, L0, L1, h0, h1, nq, c0, p0,
                              p1, np_, Iint, general, Ex, tau0, tau1, den1, C, beta, r0, r1)
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


@njit(cache=True)
def _flow_derivative(dT0, dT1, dq0, dq1, dL1, t0, t1, L0, L1, h0, h1, nq, c0, p0, p1, np_,
                     Iint, general, Ex, tau0, tau1, den, C, beta, r0, r1):  # pragma: no cover
    """Directional derivative of the exact 2D slip update (see _slip_flow) along
    (dT_prev, dq, dL1); returns the change of the new force (2 components)."""
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


@njit(cache=True)
def _reclose(p, k, kprev, u, v, kt, kn, n0, E, want_jac, nc, vcol, cn0, Tp, dT):
    """Predictor of a contact that closes inside (kprev, k): T was 0 and sticking
    starts where the normal gap closes, ``Tp = kt (1 - s) (u_k - u_kprev)`` with
    ``s = Nu_prev / (Nu_prev - Nu_k)``, ``Nu = n0 + kn v``. dT (zero while open)
    becomes dTp."""  # pragma: no cover
    d = Tp.size
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


@njit(cache=True)
def _coeff_weight(c, theta, ns, corder, ckind):
    """Analysis weight a_c(theta) and its derivative d a_c / d theta."""  # pragma: no cover
    if ckind[c] == 0:
        return 1.0 / ns, 0.0
    n = corder[c]
    if ckind[c] == 1:
        return 2.0 / ns * np.cos(n * theta), -2.0 / ns * n * np.sin(n * theta)
    return 2.0 / ns * np.sin(n * theta), 2.0 / ns * n * np.cos(n * theta)


@njit(cache=True)
def _slopes(c, theta, corder, ckind):
    """d/dtheta and d2/dtheta2 of the basis function of coefficient c."""  # pragma: no cover
    if ckind[c] == 0:
        return 0.0, 0.0
    n = corder[c]
    if ckind[c] == 1:
        return -n * np.sin(n * theta), -n * n * np.cos(n * theta)
    return n * np.cos(n * theta), -n * n * np.sin(n * theta)


@njit(cache=True)
def _kinks(p, g, kt, kn, mu, n0, u, v, E, corder, ckind, has_normal, want_jac,
           T_out, N_out, state_out, G, F_out, J_out, D_out):  # pragma: no cover
    """Add the sub-sample kink corrections of one point's final period.

    The periodic trapezoid rule across a slope jump J (per radian) at fraction
    s of an interval errs by ``(s (1 - s) - 1/6) h^2 J / 2`` (Euler-Maclaurin);
    that is subtracted. The kink is located on the linear interpolant of the
    samples; J comes from the exact slopes of the trigonometric inputs there,
    so the correction varies continuously as a kink crosses a sample.
    g: (P, c, nc) input coefficients."""
    d, ns = u.shape[1], u.shape[2]
    nc = E.shape[1]
    m = J_out.shape[3] + 1
    vcol = d * nc
    h = 2.0 * np.pi / ns
    rows = d + 1
    last = rows if has_normal else d
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
    for k in range(ns):
        kprev = k - 1 if k > 0 else ns - 1
        s0, s1 = state_out[p, kprev], state_out[p, k]
        kind = 0
        if s0 == SAMPLE_STICK and s1 == SAMPLE_SLIP:
            kind = 1
        elif has_normal and s0 != SAMPLE_OPEN and s1 == SAMPLE_OPEN:
            kind = 2
        elif has_normal and s0 == SAMPLE_OPEN and s1 != SAMPLE_OPEN:
            kind = 3
        if kind == 0:
            continue
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
            s = _crossing(p, k, kprev, a, da, kn, mu, E, has_normal, want_jac, T_out, N_out,
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
        upp = np.zeros(d)
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


@njit(cache=True)
def _crossing(p, k, kprev, a, da, kn, mu, E, has_normal, want_jac, T_out, N_out,
              G, ds, nvec, dn):  # pragma: no cover
    """Fraction s of (kprev, k) where the linear predictor ``T_prev + s a``
    from a stuck sample reaches the limit ``L0 + s b`` (b = mu (N_k - N_prev));
    fills ds, the direction n = T_c / L_c there and dn."""
    d = a.size
    nc = E.shape[1]
    m = ds.size
    vcol = d * nc
    L0 = mu[p] * N_out[p, kprev]
    b = mu[p] * N_out[p, k] - L0
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
            dl1 = mu[p] if N_out[p, k] > 0.0 else 0.0
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
