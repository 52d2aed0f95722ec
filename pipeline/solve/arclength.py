"""Pseudo-arclength continuation (Firrone & Zucca 7.2, eqs. 55-56): tangent predictor,
corrector on the hyperplane orthogonal to the tangent, adaptive step, turning points (the
parameter reversing between points) followed and reported; corners of a non-smooth branch
crossed at a fixed parameter, square-root cusps leapt."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .branch import Branch, Collector, NewtonResult, check_range
from .newton import (
    DEFAULT,
    ON_BRANCH,
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
    try:
        return _arclength_steps(fun, out, x, lam, first_tangent, xs, lam_scale, direction,
                                start, stop, f_scale, settings, progress, parameter, watch)
    except KeyboardInterrupt:
        return out.finish("interrupted", f"interrupted by the user after {parameter} = "
                          f"{out.values[-1]:.6g}")


def _arclength_steps(fun, out, x, lam, first_tangent, xs, lam_scale, direction, start, stop,
                     f_scale, settings, progress, parameter, watch):
    tangent, orientation = first_tangent
    rms = rms_norm(x)
    h = h_good = settings.step  # the step, and the last one the corrector converged from
    corners = misses = leaps = 0  # corners crossed; correctors missed in a row; leaps
    while len(out) < settings.max_points:
        y = np.append(x / xs, lam / lam_scale)
        pred = y + h * tangent
        lam_p = pred[-1] * lam_scale
        if (lam_p - stop) * direction >= 0 and abs(tangent[-1]) > 1e-3:
            # overshoot: land exactly on the end value, at fixed lam
            frac = (stop - lam) / (lam_p - lam)
            guess = (y + frac * h * tangent)[:-1] * xs
            r = newton(fun, guess, stop, x_scale=xs / rms, f_scale=f_scale,
                       settings=settings)
            out.steps += 1
            if r.converged:
                out.add(stop, r)
                if progress:
                    progress(len(out), stop, r.iterations)
                return out.finish("complete", "")
            h /= 2
            out.failed = (stop, r.x)
            if h < settings.min_step:
                return out.finish("stopped", f"no solution at the end value {stop:.6g}: {r.reason}")
            continue
        ok, y_new, its, res, info = corrector(fun, pred, tangent, xs, lam_scale, f_scale,
                                             settings)
        out.steps += 1
        far = ok and np.linalg.norm(y_new - pred) > ON_BRANCH * h
        if not ok or far:
            h /= 2
            misses += 1
            if not ok:
                out.failed = (y_new[-1] * lam_scale, y_new[:-1] * xs)
            if h >= settings.min_step and (misses != CORNER_MISSES or corners >= MAX_CORNERS):
                continue
            # a corner of the branch (e.g. the whole orbit passing from stick to slip at
            # once): the tangent is undefined there, but a step at fixed parameter
            # crosses it; then arclength resumes
            crossed = None
            if corners < MAX_CORNERS:
                corners += 1
                crossed = _cross_corner(fun, x, lam, tangent[-1], lam_scale, xs, f_scale,
                                        settings)
            if crossed is not None:
                lam_c, r = crossed
                crossed_tangent = branch_tangent(fun, r.x, lam_c, xs, lam_scale, f_scale, tangent,
                                           direction)
                if crossed_tangent is None:
                    return out.finish("stopped", f"singular Jacobian at {parameter} = "
                                      f"{lam_c:.6g}")
                t_c, orientation = crossed_tangent
                if t_c[-1] * (lam_c - lam) < 0:  # keep going the way the crossing went
                    t_c, orientation = -t_c, -orientation
                out.add(lam_c, r)
                if progress:
                    progress(len(out), lam_c, r.iterations)
                x, lam, tangent, h, misses = r.x, lam_c, t_c, settings.step, 0
                h_good = h
                continue
            if h >= settings.min_step:
                continue  # not a corner: shorter steps go on
            # no step is short enough: a point where the branch is continuous but not
            # differentiable (a square-root cusp, see LEAP_GROWTH), which a longer step passes
            leapt = None
            leaps += 1  # beyond MAX_LEAPS: none tried
            if leaps <= MAX_LEAPS:
                leapt, tries = _leap(fun, x, lam, tangent, h_good, xs, lam_scale, f_scale,
                                     settings, stop, direction)
                out.steps += tries
            if leapt is None:
                why = f"corrector failed ({info})" if not ok else \
                    "the corrector keeps leaving the branch"
                longer = (f" and longer steps to max_step = {settings.max_step:g}" if
                          leaps <= MAX_LEAPS else f" (all {MAX_LEAPS} leaps used)")
                return out.finish("stopped", f"stopped near {parameter} = {lam:.6g}: {why} "
                                  f"with step below min_step = {settings.min_step:g}{longer}")
            y_new, its, res, info, h = leapt
            leapt_from = y  # past a non-smooth point: go on the way the leap went
        else:
            leapt_from = None
        misses, h_good = 0, h
        x_new, lam_new = y_new[:-1] * xs, y_new[-1] * lam_scale
        new_tangent = branch_tangent(fun, x_new, lam_new, xs, lam_scale, f_scale, tangent,
                               direction, info)
        if new_tangent is None:
            return out.finish("stopped", f"singular Jacobian at {parameter} = {lam_new:.6g}")
        t_new = new_tangent[0] * new_tangent[1] * orientation
        if leapt_from is not None and t_new @ (y_new - leapt_from) < 0:
            t_new, orientation = -t_new, -orientation  # det's sign across the cusp: unsure
        if not settings.lower < lam_new < settings.upper:
            return out.finish("stopped", f"the branch left the admissible range "
                              f"({settings.lower:g}, {settings.upper:g}) of {parameter} "
                              f"after {lam:.6g}")
        out.add(lam_new, NewtonResult(x_new, True, its, res))
        if progress:
            progress(len(out), lam_new, its)
        stall = _stalled(out, lam_scale)
        if stall:
            return out.finish("stopped", f"stalled at {parameter} = {lam_new:.6g}: {stall}")
        seen = watch(lam_new, x_new) if watch else ""
        if seen:
            return out.finish("stopped", seen)
        h = adapted_step(h, t_new, tangent, its, settings)
        x, lam, tangent = x_new, lam_new, t_new
        # dynamic scaling: the unknowns' scale follows the largest amplitude met,
        # so a resonance 100x the start amplitude does not take 100x the points
        grow = np.max(np.abs(x)) * rms / xs
        if np.any(grow > 1.0):
            new_xs = np.maximum(xs, np.max(np.abs(x)) * rms)
            tangent = np.append(tangent[:-1] * xs / new_xs, tangent[-1])
            tangent /= np.linalg.norm(tangent)
            xs = new_xs
        if (lam - start) * direction < -0.5 * lam_scale:
            return out.finish("stopped", f"branch turned back past the start ({lam:.6g})")
    return out.finish("stopped", f"max_points = {settings.max_points} reached at {lam:.6g}")


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
        r = newton(fun, x, lam_c, x_scale=xs / rms_norm(x), f_scale=f_scale, settings=settings)
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


def _leap_steps(h_good: float, settings: Settings) -> np.ndarray:
    """The leaps' steps: 2 h_good growing by LEAP_GROWTH to max_step (which ends them)."""
    first = min(2.0 * h_good, settings.max_step)
    n = int(np.ceil(np.log(settings.max_step / first) / np.log(LEAP_GROWTH))) if \
        first < settings.max_step else 0
    return np.minimum(first * LEAP_GROWTH ** np.arange(n + 1), settings.max_step)


def _leap(fun, x, lam, tangent, h_good, xs, lam_scale, f_scale, settings, stop, direction):
    """The corrector from steps of :func:`_leap_steps` along ``tangent`` from the last
    solution (x, lam), each predictor short of ``stop``: ((y, iterations, residual, info,
    step), tries) of the first that converges on the branch (ON_BRANCH, as any step) and
    moves the parameter the way the tangent does (where it moves it), else (None, tries)."""
    y0 = np.append(x / xs, lam / lam_scale)
    tries = 0
    for h in _leap_steps(h_good, settings):
        pred = y0 + h * tangent
        if (pred[-1] * lam_scale - stop) * direction >= 0:
            break  # the end value is the ordinary step's to land on
        tries += 1
        ok, y, its, res, info = corrector(fun, pred, tangent, xs, lam_scale, f_scale, settings)
        onward = abs(tangent[-1]) < 1e-3 or (y[-1] - y0[-1]) * tangent[-1] > 0
        if ok and onward and np.linalg.norm(y - pred) <= ON_BRANCH * h:
            return (y, its, res, info, h), tries
    return None, tries
