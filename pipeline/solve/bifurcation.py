"""Bifurcations along a branch: detected from the stability of its points, located between
them and named (issue 25, section 2).

Each point's unstable Floquet exponents (:mod:`.stability`) fall in three classes by where
their multiplier exp(lambda T) leaves the unit circle:

    real       |Im lambda| ~ 0        through +1: a fold (the parameter turns back there:
                                      at a point, or past both points' values) or a
                                      branch point (it does not)
    flip       |Im lambda| ~ w / 2    through -1: period doubling
    complex    otherwise              a complex pair: Neimark-Sacker (quasi-periodic motion)

Where the count of a class changes between consecutive points, the test function (the
largest real part among the class's exponents) is followed along the branch between them:
points on the chord's normal planes (the arclength corrector) by regula falsi (Illinois)
to its zero, bisection on the count where the class is empty at one end, until the
bracket is below LOCATED of the step or the real part within ZERO w of zero.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import continuation as cont
from .response import Response, problem, scales
from .stability import NEUTRAL, Stability, hill_stability

KINDS = ("fold", "branch point", "period doubling", "Neimark-Sacker")
CLASSES = ("real", "flip", "complex")
#: An exponent is real when |Im| <= REAL w, a flip one when |Im| >= (1 - EDGE) w / 2 (the
#: truncated Hill problem puts the pair of a multiplier on the negative axis near, not at,
#: the strip's edge).
REAL, EDGE = 1e-6, 1e-2
#: The bracket's share of the step at which a bifurcation counts as located, and the real
#: part (x w) that counts as zero there.
LOCATED, ZERO = 1e-4, 1e-9
#: Trials per bifurcation, and bifurcations located per branch (a branch through a
#: non-smooth region can change stability at many points: the rest are reported at the
#: midpoint of their bracket, unlocated).
TRIALS, MOST = 30, 25


@dataclass(frozen=True)
class Bifurcation:
    """kind: one of KINDS; index: the point before it (between ``index`` and ``index + 1``);
    parameter, omega [rad/s]: where; exponent: the critical Floquet exponent there [1/s];
    x: the solution there (the balance's unknowns); located: found to LOCATED of the step
    (False: the last trial point, or the bracket's midpoint where none converged)."""

    kind: str
    index: int
    parameter: float
    omega: float
    exponent: complex
    x: np.ndarray
    located: bool = True


def exponent_classes(exponents: np.ndarray, omega: float) -> np.ndarray:
    """(k,) index into CLASSES of each exponent."""
    im = np.abs(np.asarray(exponents).imag)
    return np.where(im <= REAL * omega, 0, np.where(im >= (1 - EDGE) * 0.5 * omega, 1, 2))


def unstable_counts(s: Stability, omega: float) -> tuple[int, int, int]:
    """Unstable exponents per class of CLASSES."""
    cls = exponent_classes(s.exponents, omega)[s.exponents.real > NEUTRAL * omega]
    return tuple(int(np.count_nonzero(cls == k)) for k in range(3))


def critical(s: Stability, omega: float, cls: int) -> complex | None:
    """The exponent of class ``cls`` with the largest real part (None: none of it)."""
    lam = s.exponents[exponent_classes(s.exponents, omega) == cls]
    return complex(lam[np.argmax(lam.real)]) if lam.size else None


def find_bifurcations(r: Response, stabilities: list[Stability],
                      settings: cont.Settings = cont.DEFAULT) -> list[Bifurcation]:
    """Every bifurcation between consecutive points of ``r`` (``stabilities``: one per
    point), located and named, in branch order; a natural sweep's jumps are no part of it."""
    n = len(r)
    if n < 2:
        return []
    jumps = {i for i, _ in r.branch.jumps}
    values = r.values
    fun = problem(r.model, r.base, r.parameter)
    xs, fs = scales(r.model, r.point(0))
    xs = max(xs, float(np.max(np.abs(r.branch.x)))) if r.branch.x.size else xs
    lam_scale = float(np.ptp(values)) or 1.0
    turning = set(r.branch.turning_points)
    counts = [unstable_counts(s, r.point(i).omega) for i, s in enumerate(stabilities)]
    out: list[Bifurcation] = []
    for i, cls in _changes(values, counts, jumps):
        kind = ("", KINDS[2], KINDS[3])[cls]  # a real one: a fold or a branch point, below

        def at(lam: float, x: np.ndarray) -> Stability:
            return hill_stability(r.model, x, r.base.set(r.parameter, lam))

        def solve(fraction: float, i=i):
            return cont.on_chord(fun, (values[i], r.branch.x[i]),
                                 (values[i + 1], r.branch.x[i + 1]), fraction,
                                 x_scale=xs, lam_scale=lam_scale, f_scale=fs,
                                 settings=settings)

        found = _locate(solve, at, r, cls, counts[i][cls], stabilities[i],
                        stabilities[i + 1], i) if len(out) < MOST else None
        if found is None:  # unlocated: at the bracket's midpoint, the far end's exponent
            exp = critical(stabilities[i + 1], r.point(i + 1).omega, cls)
            found = (0.5 * (values[i] + values[i + 1]),
                     0.5 * (r.branch.x[i] + r.branch.x[i + 1]),
                     complex(np.nan) if exp is None else exp, False)
        lam, x, exponent, located = found
        if not kind:  # the parameter turns back: at a point, or between two (a natural
            # sweep's last point before its jump lies past the fold)
            lo, hi = sorted((values[i], values[i + 1]))
            slack = 1e-12 * max(abs(lo), abs(hi))  # the chord's rounding
            beyond = not lo - slack <= lam <= hi + slack
            kind = KINDS[0] if (turning & {i, i + 1} or beyond) else KINDS[1]
        out.append(Bifurcation(kind, i, float(lam), r.base.set(r.parameter, lam).omega,
                               complex(exponent), x, located))
    return out


#: Changes of stability whose points (and every point between) lie within a parameter span
#: below CLUSTER of the branch's range form one cluster: a branch circling a stick/slip
#: kink (its points a hair apart, the Jacobian jumping between the kink's sides, and the
#: exponents with it) changes stability back and forth without any physical meaning.
CLUSTER = 1e-6


def _changes(values: np.ndarray, counts: list[tuple[int, int, int]], jumps: set[int]
             ) -> list[tuple[int, int]]:
    """(i, class) where the count of unstable exponents of the class changes between
    points i and i + 1, in branch order; a cluster (CLUSTER) with no net change counts
    for none and one with a net change for its first change."""
    span = CLUSTER * (float(np.ptp(values)) or 1.0)
    raw = [(i, c) for i in range(len(values) - 1) if i not in jumps for c in range(3)
           if counts[i][c] != counts[i + 1][c]]
    out = []
    for c in range(3):
        mine = [i for i, k in raw if k == c]
        while mine:
            group = [mine.pop(0)]
            while mine and np.ptp(values[group[0]: mine[0] + 2]) < span:
                group.append(mine.pop(0))
            if len(group) == 1 or counts[group[0]][c] != counts[group[-1] + 1][c]:
                out.append((group[0], c))
    return sorted(out)


def _locate(solve: Callable, at: Callable, r: Response, cls: int, count0: int,
            s0: Stability, s1: Stability, i: int):
    """(parameter, x, critical exponent, located) where the class ``cls``'s largest real
    part crosses zero between points i and i + 1 (the count of unstable exponents then
    changes; by that count where the class is empty at an end). located: to LOCATED of
    the step or the real part within ZERO w of zero; False: the trials ran out. None where
    the branch between the points cannot be followed."""
    w0, w1 = r.point(i).omega, r.point(i + 1).omega
    g0, g1 = (_test(s, w, cls) for s, w in ((s0, w0), (s1, w1)))
    sign0 = None if g0 is None or g1 is None or g0 * g1 >= 0 else np.sign(g0)
    a, b = 0.0, 1.0
    side = 0  # Illinois: which end was replaced last (-1: a, 1: b)
    best = None
    for _ in range(TRIALS):
        if sign0 is not None:
            t = a + (b - a) * g0 / (g0 - g1)
            t = min(max(t, a + 0.01 * (b - a)), b - 0.01 * (b - a))
        else:
            t = 0.5 * (a + b)
        hit = solve(t)
        if hit is None:
            return None if best is None else (*best, False)
        lam, res = hit
        s = at(lam, res.x)
        w = r.base.set(r.parameter, lam).omega
        exp = critical(s, w, cls)
        g = _test(s, w, cls)
        best = (lam, res.x, complex(np.nan) if exp is None else exp)
        if g is not None and abs(g) <= ZERO * w:
            return (*best, True)
        if g is None:  # the class emptied here: its real part is no guide any more
            sign0 = None
        if sign0 is not None:
            low = np.sign(g) == sign0
        else:
            low = unstable_counts(s, w)[cls] == count0
        if low:
            a, g0 = t, g
            if side == -1 and g1 is not None:
                g1 *= 0.5
            side = -1
        else:
            b, g1 = t, g
            if side == 1 and g0 is not None:
                g0 *= 0.5
            side = 1
        if b - a <= LOCATED:
            return (*best, True)
    return (*best, False)


def _test(s: Stability, omega: float, cls: int) -> float | None:
    """The test function of class ``cls``: its largest real part (None: no exponent of
    the class)."""
    e = critical(s, omega, cls)
    return None if e is None else e.real
