"""Pseudo-arclength continuation (Firrone & Zucca 7.2, eqs. 55-56): tangent predictor,
corrector on the hyperplane orthogonal to the tangent, adaptive step, turning points (the
parameter reversing between points) followed and reported; corners of a non-smooth branch
crossed at a fixed parameter, square-root cusps leapt."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .branch import Branch, Collector, NewtonResult, check_range
from .newton import (
    DEFAULT,
    ON_BRANCH,
    STALL,
    Problem,
    Settings,
    adapted_step,
    branch_tangent,
    corrector,
    newton,
    rms_norm,
)

MAX_CORNERS = 20  # fixed-parameter crossings of a non-smooth branch, per branch


#: After this many correctors missed in a row (the step 2^-6 of what it was), a corner is
#: tried before any shorter step: at a corner no step is short enough, and halving down to
#: min_step costs some 15 more failed correctors each time.
CORNER_MISSES = 6


def arclength(
    fun: Problem,
    x0: np.ndarray,
    start: float,
    stop: float,
    *,
    parameter: str = "lambda",
    x_scale: float | np.ndarray = 1.0,
    f_scale: float = 1.0,
    settings: Settings = DEFAULT,
    progress: Callable[[int, float, int], None] | None = None,
    watch: Callable[[float, np.ndarray], str] | None = None,
) -> Branch:
    """Pseudo-arclength continuation from ``start`` until ``stop`` is passed.

    ``watch(lam, x)``, called at each new point: a non-empty answer stops the branch there
    ("stopped", the answer its message).

    Scaled unknowns ``y = [x / (x_scale sqrt(n)), lam / lam_scale]`` with ``lam_scale =
    |stop - start|``; steps ``h`` are arc lengths in that metric. The unknowns enter by
    their root mean square, not their sum: a step then moves the parameter by the same
    share of its range for one unknown or 1296 (a 2-norm over n unknowns would give the
    parameter a weight 1 / sqrt(n), and a full-scale FRF thousands of points)."""
    check_range(start, stop, parameter)
    lam_scale = abs(stop - start)
    direction = np.sign(stop - start)
    rms = rms_norm(x0)
    xs = np.broadcast_to(np.asarray(x_scale, float), np.shape(x0)) * rms
    out = Collector(parameter)
    # Newton's step cap is per unknown: the unknowns' own scale, without the metric's rms
    first = newton(fun, x0, start, x_scale=xs / rms, f_scale=f_scale, settings=settings)
    out.steps += 1
    if not first.converged:
        out.failed = (start, first.x)
        return out.finish("stopped", f"no solution at {parameter} = {start:.6g}: {first.reason}")
    out.add(start, first)
    if progress:
        progress(len(out), start, first.iterations)
    x, lam = first.x, start
    first_tangent = branch_tangent(fun, x, lam, xs, lam_scale, f_scale, None, direction)
    if first_tangent is None:
        return out.finish("stopped", f"singular Jacobian at {parameter} = {lam:.6g}")
    tangent, orientation = first_tangent
    walk = _Walk(fun, out, start, stop, lam_scale, direction, f_scale, settings, parameter,
                 progress, watch, x, lam, tangent, orientation, xs, rms_norm(x))
    try:
        return walk.steps()
    except KeyboardInterrupt:
        return out.finish("interrupted", f"interrupted by the user after {parameter} = "
                          f"{out.values[-1]:.6g}")


def walk_to(fun: Problem, x: np.ndarray, lam: float, tangent: np.ndarray, orientation: float,
            stop: float, *, lam_scale: float, xs: np.ndarray, f_scale: float,
            settings: Settings, parameter: str = "lambda") -> Branch:
    """Pseudo-arclength from the solution ``x`` (n,) at ``lam`` along its unit tangent (in
    y = [x / xs, lam / lam_scale], oriented by the sign ``orientation`` of det [J dR; t]),
    until ``stop`` is passed, with :func:`arclength`'s corners and leaps. The branch after
    (x, lam), its ``steps`` the correctors spent; it stops where the parameter turns back
    more than lam_scale / 2 behind ``lam``."""
    out = Collector(parameter)
    walk = _Walk(fun, out, lam, stop, lam_scale, float(np.sign(stop - lam)), f_scale,
                 settings, parameter, None, None, x, lam, tangent, orientation, xs,
                 rms_norm(x))
    return walk.steps()


@dataclass
class _Walk:
    """A pseudo-arclength continuation under way: the problem and its fixed scales, and the
    state that moves along the branch: the last point (x, lam), its unit tangent in the
    scaled unknowns y = [x / xs, lam / lam_scale] with the orientation it was given, the
    unknowns' scale xs (growing with the largest amplitude met), the step h and h_good (the
    last one the corrector converged from), and the corners crossed, correctors missed in a
    row and leaps taken."""

    fun: Problem
    out: Collector
    start: float
    stop: float
    lam_scale: float
    direction: float
    f_scale: float
    settings: Settings
    parameter: str
    progress: Callable[[int, float, int], None] | None
    watch: Callable[[float, np.ndarray], str] | None
    x: np.ndarray
    lam: float
    tangent: np.ndarray
    orientation: float
    xs: np.ndarray
    rms: float  # of the first point: Newton's step cap is per unknown
    corners: int = 0
    misses: int = 0
    leaps: int = 0
    leapt_short: float = 0.0  # h_good of the last early leap that missed

    def __post_init__(self) -> None:
        self.h = self.h_good = self.settings.step

    def steps(self) -> Branch:
        """Steps until the branch reaches ``stop`` or stops (the reason in its message)."""
        s = self.settings
        while len(self.out) < s.max_points:
            y = np.append(self.x / self.xs, self.lam / self.lam_scale)
            pred = y + self.h * self.tangent
            lam_p = pred[-1] * self.lam_scale
            if (lam_p - self.stop) * self.direction >= 0 and abs(self.tangent[-1]) > 1e-3:
                landed = self._land(y, lam_p)
                if landed is not None:
                    return landed
                continue
            ok, y_new, its, res, info = corrector(self.fun, pred, self.tangent, self.xs,
                                                 self.lam_scale, self.f_scale, s)
            self.out.steps += 1
            leapt_from = None
            if not ok or np.linalg.norm(y_new - pred) > ON_BRANCH * self.h:
                self.h /= 2
                self.misses += 1
                if not ok:
                    self.out.failed = (y_new[-1] * self.lam_scale, y_new[:-1] * self.xs)
                after = self._after_miss(ok, info)
                if after is None:
                    continue
                if isinstance(after, Branch):
                    return after
                y_new, its, res, info, self.h = after
                leapt_from = y  # past a non-smooth point: go on the way the leap went
            done = self._accept(y_new, its, res, info, leapt_from)
            if done is not None:
                return done
        return self.out.finish("stopped", f"max_points = {s.max_points} reached at "
                               f"{self.lam:.6g}")

    def _after_miss(self, ok: bool, info) -> tuple | Branch | None:
        """After a missed corrector (the step already halved): a leap that landed (y,
        iterations, residual, info, step), the Branch where the walk ends, or None to go on
        (shorter steps, or from a corner's point past it)."""
        s = self.settings
        if self.misses == EARLY_LEAP_MISSES:
            early = self._early_leap()
            if early is not None:
                return early
        if self.h >= s.min_step and (self.misses != CORNER_MISSES
                                     or self.corners >= MAX_CORNERS):
            return None
        crossed = self._corner()
        if crossed is not None:  # a point past it (True), or why the branch stops there
            return crossed if isinstance(crossed, Branch) else None
        if self.h >= s.min_step:
            return None  # not a corner: shorter steps go on
        leapt = self._leap()
        return leapt if leapt is not None else self._stuck(ok, info)

    def _land(self, y: np.ndarray, lam_p: float) -> Branch | None:
        """The predictor overshot ``stop``: Newton exactly on it, at fixed parameter. The
        finished branch, or None to go on with half the step."""
        frac = (self.stop - self.lam) / (lam_p - self.lam)
        guess = (y + frac * self.h * self.tangent)[:-1] * self.xs
        r = newton(self.fun, guess, self.stop, x_scale=self.xs / self.rms,
                   f_scale=self.f_scale, settings=self.settings, stall=STALL)
        self.out.steps += 1
        if r.converged:
            self._add(self.stop, r)
            return self.out.finish("complete", "")
        self.h /= 2
        self.out.failed = (self.stop, r.x)
        if self.h < self.settings.min_step:
            return self.out.finish("stopped", f"no solution at the end value {self.stop:.6g}: "
                                   f"{r.reason}")
        return None

    def _corner(self) -> Branch | bool | None:
        """A corner of the branch (e.g. the whole orbit passing from stick to slip at once):
        the tangent is undefined there, but a step at fixed parameter crosses it; then
        arclength resumes from the point past it (True), or the branch stops (a Branch).
        None when no corner was crossed."""
        if self.corners >= MAX_CORNERS:
            return None
        self.corners += 1
        crossed = _cross_corner(self.fun, self.x, self.lam, self.tangent[-1], self.lam_scale,
                                self.xs, self.f_scale, self.settings)
        if crossed is None:
            return None
        lam_c, r = crossed
        found = branch_tangent(self.fun, r.x, lam_c, self.xs, self.lam_scale, self.f_scale,
                               self.tangent, self.direction)
        if found is None:
            return self.out.finish("stopped", f"singular Jacobian at {self.parameter} = "
                                   f"{lam_c:.6g}")
        t_c, self.orientation = found
        if t_c[-1] * (lam_c - self.lam) < 0:  # keep going the way the crossing went
            t_c, self.orientation = -t_c, -self.orientation
        self._add(lam_c, r)
        self.x, self.lam, self.tangent, self.misses = r.x, lam_c, t_c, 0
        self.h = self.h_good = self.settings.step
        return True

    def _leap(self) -> tuple | None:
        """No step is short enough: a point where the branch is continuous but not
        differentiable (a square-root cusp, see LEAP_GROWTH), which a longer step passes.
        (y, iterations, residual, info, step) of the leap, or None (none converged, or all
        MAX_LEAPS used)."""
        self.leaps += 1
        if self.leaps > MAX_LEAPS:
            return None
        leapt, tries = _leap(self.fun, self.x, self.lam, self.tangent, self.h_good, self.xs,
                             self.lam_scale, self.f_scale, self.settings, self.stop,
                             self.direction)
        self.out.steps += tries
        return leapt

    def _early_leap(self) -> tuple | None:
        """Two correctors missed in a row: before the steps shrink towards a cusp, where
        no short step converges (LEAP_GROWTH), the first EARLY_LEAPS leaps. (y,
        iterations, residual, info, step) of the one that landed on the branch, or None.
        One that missed is not tried again until the steps have grown past its start (a
        leap from a shorter good step is shorter still)."""
        if self.leapt_short / EARLY_SPACING <= self.h_good <= self.leapt_short:
            return None
        if abs(self.tangent[-1]) < 1e-3:  # at a fold: shorter steps round it, not a leap
            return None
        leapt, tries = _leap(self.fun, self.x, self.lam, self.tangent, self.h_good, self.xs,
                             self.lam_scale, self.f_scale, self.settings, self.stop,
                             self.direction, EARLY_LEAPS)
        self.out.steps += tries
        if leapt is None:
            self.leapt_short = self.h_good
        return leapt

    def _stuck(self, ok: bool, info) -> Branch:
        """The branch stopped: no step, short or long, converged on it."""
        s = self.settings
        why = f"corrector failed ({info})" if not ok else \
            "the corrector keeps leaving the branch"
        longer = (f" and longer steps to max_step = {s.max_step:g}" if
                  self.leaps <= MAX_LEAPS else f" (all {MAX_LEAPS} leaps used)")
        return self.out.finish("stopped", f"stopped near {self.parameter} = {self.lam:.6g}: "
                               f"{why} with step below min_step = {s.min_step:g}{longer}")

    def _accept(self, y_new: np.ndarray, its: int, res: float, info,
                leapt_from: np.ndarray | None) -> Branch | None:
        """Keep the corrected point and step on from it; a Branch when the branch ends
        there (a singular Jacobian, out of range, stalled, stopped by ``watch``)."""
        s = self.settings
        self.misses, self.h_good = 0, self.h
        x_new, lam_new = y_new[:-1] * self.xs, y_new[-1] * self.lam_scale
        found = branch_tangent(self.fun, x_new, lam_new, self.xs, self.lam_scale,
                               self.f_scale, self.tangent, self.direction, info)
        if found is None:
            return self.out.finish("stopped", f"singular Jacobian at {self.parameter} = "
                                   f"{lam_new:.6g}")
        t_new = found[0] * found[1] * self.orientation
        if leapt_from is not None and t_new @ (y_new - leapt_from) < 0:
            t_new, self.orientation = -t_new, -self.orientation  # det's sign across the cusp
        if not s.lower < lam_new < s.upper:
            return self.out.finish("stopped", f"the branch left the admissible range "
                                   f"({s.lower:g}, {s.upper:g}) of {self.parameter} "
                                   f"after {self.lam:.6g}")
        self._add(lam_new, NewtonResult(x_new, True, its, res))
        stall = _stalled(self.out, self.lam_scale)
        if stall:
            return self.out.finish("stopped", f"stalled at {self.parameter} = {lam_new:.6g}: "
                                   f"{stall}")
        seen = self.watch(lam_new, x_new) if self.watch else ""
        if seen:
            return self.out.finish("stopped", seen)
        self.h = adapted_step(self.h, t_new, self.tangent, its, s)
        self.x, self.lam, self.tangent = x_new, lam_new, t_new
        self._rescale()
        if (self.lam - self.start) * self.direction < -0.5 * self.lam_scale:
            return self.out.finish("stopped", f"branch turned back past the start "
                                   f"({self.lam:.6g})")
        return None

    def _add(self, lam: float, r: NewtonResult) -> None:
        self.out.add(lam, r)
        if self.progress:
            self.progress(len(self.out), lam, r.iterations)

    def _rescale(self) -> None:
        """Dynamic scaling: the unknowns' scale follows the largest amplitude met, so a
        resonance 100x the start amplitude does not take 100x the points."""
        grow = np.max(np.abs(self.x)) * self.rms / self.xs
        if np.any(grow > 1.0):
            new_xs = np.maximum(self.xs, np.max(np.abs(self.x)) * self.rms)
            tangent = np.append(self.tangent[:-1] * self.xs / new_xs, self.tangent[-1])
            self.tangent = tangent / np.linalg.norm(tangent)
            self.xs = new_xs


#: A continuation has stalled when its last STALL_POINTS points moved the parameter by
#: less than STALL_SPAN of its range: the step is spent on the unknowns alone (a response
#: running off to infinity at an undamped resonance, or a branch circling at a kink),
#: and more points would only pile up there.
STALL_POINTS = 50


STALL_SPAN = 1e-6


def _stalled(out: Collector, lam_scale: float) -> str:
    """Why the branch has stalled ("" if it has not)."""
    if len(out) <= STALL_POINTS:
        return ""
    recent = out.values[-STALL_POINTS:]
    spread = max(recent) - min(recent)
    if spread >= STALL_SPAN * lam_scale:
        return ""
    first, last = (float(np.max(np.abs(out.xs[i]))) for i in (-STALL_POINTS, -1))
    grew = f"; the largest unknown went from {first:.3g} to {last:.3g}" if last > first else ""
    return (f"the last {STALL_POINTS} points moved it by {spread:.2g} only (less than "
            f"{STALL_SPAN:g} x its range {lam_scale:.4g}){grew}: the response changes at a "
            "fixed parameter (an undamped resonance that friction does not bound, or a kink "
            "the steps circle around)")


def _cross_corner(fun, x, lam, slope, lam_scale, xs, f_scale, settings):
    """Newton at fixed parameter just past ``lam`` in the branch's direction
    (from the last solution): (lam, NewtonResult) or None."""
    sign = np.sign(slope) if slope != 0 else 1.0
    for frac in (1e-5, 1e-4, 1e-3, 1e-2):  # the shortest crossing first
        lam_c = lam + sign * frac * lam_scale
        if not settings.lower < lam_c < settings.upper:
            return None
        r = newton(fun, x, lam_c, x_scale=xs / rms_norm(x), f_scale=f_scale, settings=settings,
                   stall=STALL)  # (a crossing that stalls: the next, longer one)
        if r.converged:
            return lam_c, r
    return None


#: Steps tried past a singular point: LEAP_GROWTH^k x 2 x the last step the corrector
#: converged from, up to max_step, shortest first. A stuck 2D contact whose admissible slider
#: positions (the intersection of its samples' friction discs) shrink to a lens moves with
#: the lens' corner, as the square root of the distance to where the lens vanishes and the
#: contact starts slipping every period: the residual there rises as sqrt(h) along the
#: tangent (measured on the shrouded blisk: 4e-9 to 1.5e-3 of the force scale within 1.3e-8
#: of arc), so no short step converges, and one some 2e-3 long does (4 iterations), while
#: the steps had shrunk to 1e-6 on the way in.
LEAP_GROWTH = 4.0


MAX_LEAPS = 20  # per branch, as MAX_CORNERS


#: Misses in a row after which the first EARLY_LEAPS leaps are tried before shorter steps.
#: A whole disk's sweep meets a cusp at each of its hundreds of 2D contacts as it starts to
#: slip; each cost 20-30 failed correctors down to min_step before its leap (~400 s at 48
#: blades, 6,912 unknowns, measured), where two misses and a leap of 2 or 8 x the last
#: good step pass it. Not counted among MAX_LEAPS: each costs two misses first.
EARLY_LEAP_MISSES = 2
EARLY_LEAPS = 2
EARLY_SPACING = 16.0


def _leap_steps(h_good: float, settings: Settings) -> np.ndarray:
    """The leaps' steps: 2 h_good growing by LEAP_GROWTH to max_step (which ends them)."""
    first = min(2.0 * h_good, settings.max_step)
    n = int(np.ceil(np.log(settings.max_step / first) / np.log(LEAP_GROWTH))) if \
        first < settings.max_step else 0
    return np.minimum(first * LEAP_GROWTH ** np.arange(n + 1), settings.max_step)


def _leap(fun, x, lam, tangent, h_good, xs, lam_scale, f_scale, settings, stop, direction,
          most: int | None = None):
    """The corrector from steps of :func:`_leap_steps` along ``tangent`` from the last
    solution (x, lam), each predictor short of ``stop``: ((y, iterations, residual, info,
    step), tries) of the first that converges on the branch (ON_BRANCH, as any step) and
    moves the parameter the way the tangent does (where it moves it), else (None, tries).
    ``most``: the first so many steps only."""
    y0 = np.append(x / xs, lam / lam_scale)
    tries = 0
    for h in _leap_steps(h_good, settings)[:most]:
        pred = y0 + h * tangent
        if (pred[-1] * lam_scale - stop) * direction >= 0:
            break  # the end value is the ordinary step's to land on
        tries += 1
        ok, y, its, res, info = corrector(fun, pred, tangent, xs, lam_scale, f_scale, settings)
        onward = abs(tangent[-1]) < 1e-3 or (y[-1] - y0[-1]) * tangent[-1] > 0
        if ok and onward and np.linalg.norm(y - pred) <= ON_BRANCH * h:
            return (y, its, res, info, h), tries
    return None, tries
