"""Compiled hot loop: the friction return map marched over sampled periods.

point    one point's march to its periodic steady state (what the kernels dispatch to)
steps    one period of the return map, sample by sample, with derivatives carried
cycle    the periodic cycle of one point: plain periods, shooting, the corner cycle
kinks    sub-sample corrections: each transition located between two samples

One kernel serves the four contact laws of :mod:`..coulomb`: the tangential
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
first predictor is ``kt u_0`` (the static part included: Firrone & Zucca eqs. 26-28), and
repeats periods until the force at the end of a period repeats. A cycle that
sticks all period is periodic from any nearby start (it is not unique, and
the periodicity leaves its derivative free: Phi = I): the one returned is
where that march settles, slipping in its first periods if it must
("shakedown"), and its derivatives are those of the same march, repeated
with derivatives. When the march closes in on a corner of the stuck set
(slipping at the same two samples period after period, contracting slowly)
the cycle is the one touching the limit at both, in closed form and
differentiated implicitly (:func:`periodic_cycle`).

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

Modules: this one dispatches (``march``: serial or threaded, arguments cast to one
signature) and tells whether the kernels are compiled; ``point`` marches one point,
``cycle`` finds its periodic cycle (shooting, corners, shakedown), ``steps`` marches one
period sample by sample, ``kinks`` makes the sub-sample corrections.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numba
import numpy as np
from numba import types

from .point import march_parallel, march_serial

# numba compiles a kernel and every helper once per argument types, so march casts its
# inputs to one type each, and constants passed between the helpers are wrapped
# (np.int64(0), np.bool_(True)): a bare literal types as Literal[...] and compiles the
# callee once more per value (march_period was compiled 16 times). (dtype, ndim) per argument of
# march; ndim 0 is a scalar.
_ARGS = ((np.float64, 3), (np.float64, 3), (np.float64, 2), (np.float64, 2), (np.float64, 1),
         (np.float64, 1), (np.float64, 1), (np.float64, 2), (np.float64, 2), (np.float64, 1),
         (np.int8, 1), (np.bool_, 0), (np.bool_, 0), (np.int64, 0), (np.float64, 0),
         (np.bool_, 0), (np.float64, 3), (np.float64, 2), (np.int8, 2), (np.float64, 3),
         (np.float64, 4), (np.float64, 3), (np.int64, 1), (np.int64, 2))
_OUTPUTS = frozenset((1, 2, *range(16, 24)))  # written in place: checked, never copied
_KINDS = tuple((np.dtype(dt), nd) for dt, nd in _ARGS)
_SCALAR = {np.dtype(np.bool_): bool, np.dtype(np.int64): int, np.dtype(np.float64): float}


def _bundled(flat: tuple, pack: Callable = tuple) -> tuple:
    """march's flat arguments as the kernels take them, grouped by what they are: g, motion
    (u, v), law (kt, kn, mu, n0), dft (E, A, corder, ckind), has_normal, want_jac,
    max_periods, rtol, corrections, out (T_out, ..., counts_out). ``pack`` makes a group
    (``tuple`` of values, ``types.Tuple`` of their numba types)."""
    return (flat[0], pack(flat[1:3]), pack(flat[3:7]), pack(flat[7:11]), *flat[11:16],
            pack(flat[16:24]))


SIGNATURE = _bundled(tuple(numba.from_dtype(dt) if nd == 0 else
                           types.Array(numba.from_dtype(dt), nd, "C") for dt, nd in _KINDS),
                     types.Tuple)

# Work (points x samples x derivative columns) from which march shares the points among
# threads: a serial march costs ~23 ns per unit (laws A and D). Median ms, serial vs 2
# threads, law A (H = 1, 128 samples, 4 columns; work = 512 P): quiet cores, P = 1: 0.045 vs
# 0.053, 4: 0.077 vs 0.073, 64: 0.73 vs 0.40, 1024: 11.9 vs 6.2; under load 3-4 with
# OpenMP, P = 1: 0.045 vs 0.047 (p90 7.9: a descheduled thread stalls the join a time
# slice), 16: 0.20 vs 6.2, 256: 3.8 vs 11, 1024: 12 vs 16, 2048: 23 vs 24 (TBB: 0.96-1.04x
# at every P); law D (H = 3, 64 samples, 22 columns), loaded: P = 64: 1.9 vs 8.0, 256: 8.2
# vs 8.0. From ~12 ms a stall costs little and threads halve the time on quiet cores.
PARALLEL_MIN_WORK = 2**19
# Compile time of the serial kernel, s, told on a first run (measured 10.9 s with numba 0.60;
# 22-25 s with numba 0.68.1 in 2026-11 on a quieter machine; 42 s here on 2026-11-28, 53 s
# with the per-sample helpers inlined; 21 s on 2026-11-29 with the kernels' arrays passed
# in tuples by role, on a machine running tests beside it).
COMPILE_SECONDS = 30


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
    the periodic orbit (:func:`periodic_derivative`), or sticks all period
    (possibly touching the limit): then its start state, and so every force,
    is what the march from the start convention left (Firrone & Zucca eqs. 26-28), and
    the march is repeated with derivatives from the start (as is any march of
    at most two periods), or it sits on a corner of the stuck set
    (:func:`corner_derivative`).
    """
    args = _cast(args)
    P, ns = args[1].shape[0], args[1].shape[2]
    columns = args[20].shape[3] + 1 if args[12] else 1  # derivative columns carried, J_out
    kernel = march_parallel if parallel_pays(P, ns, columns) else march_serial
    kernel(*_bundled(args))


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
    if SIGNATURE in march_serial.overloads:
        return True
    try:  # numba's own index of the cache file, without loading the compiled code
        cache = march_serial._cache
        key = cache._index_key(SIGNATURE, march_serial.targetctx.codegen())
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
    march_serial.compile(SIGNATURE)
    progress(f"compiled the contact kernels in {time.perf_counter() - t:.1f} s")
