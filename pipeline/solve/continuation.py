"""Newton's method and continuation of solution branches (Firrone & Zucca appendix).

The problem is a callable ``fun(x, lam, jacobian) -> (R, J, R_lam)``: the
residual ``R`` (n,), its Jacobian ``J = dR/dx`` (n, n) and ``R_lam = dR/dlam``
(n,), in physical units. Unknowns and parameter are scaled internally
(``x / x_scale``, ``lam / lam_scale``, ``R / f_scale``) so that tolerances and
the arclength metric mean the same for a 1 N blade and a 30 kN disk.

* :func:`newton` - damped Newton at fixed ``lam`` (backtracking on ||R||).
* :func:`natural` - natural continuation (Firrone & Zucca 7.1): ``lam`` stepped, the last
  solutions extrapolated as predictor, the step halved where Newton fails; at a fold
  the sweep jumps to the other branch, as a slow physical sweep does (Firrone & Zucca Fig. 24).
* :func:`arclength` - pseudo-arclength continuation (Firrone & Zucca 7.2, eqs. 55-56):
  tangent predictor, corrector on the hyperplane orthogonal to the tangent,
  adaptive step, turning points (the parameter reversing between points) followed and
  reported.

Neither raises on non-convergence: the branch computed so far is returned with
``status`` and a ``message`` saying where and why it stopped.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .arclength import arclength, walk_to
from .branch import Branch, Collector, NewtonResult, check_range, same_solution
from .newton import (
    DEFAULT,
    STALL,
    Problem,
    Settings,
    branch_tangent,
    corrector,
    newton,
    rms_norm,
)

__all__ = ["DEFAULT", "Branch", "NewtonResult", "Problem", "Settings", "arclength",
           "check_range", "natural", "newton", "on_chord", "same_solution", "solutions_at"]


def natural(
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
    guesses: Callable[[float], list[np.ndarray]] | None = None,
) -> Branch:
    """Natural continuation from ``start`` to ``stop`` in steps of
    ``settings.step * |stop - start|`` (halved down to ``min_step`` on failure).

    Where the predictor fails, Newton restarts from the last solution. Where the step has
    fallen below ``min_step``, the branch ends within it: a fold. The sweep then jumps, as a
    slow physical sweep does (Firrone & Zucca Fig. 24): it lands at the next value, one
    regular step on, on the branch that the fold's own branch reaches there after turning
    back (followed by arclength, :func:`_detour`), else on a solution from
    ``guesses(value)``; the jump is kept in ``Branch.jumps``. Where neither gives a solution
    (the end of the solution set), the sweep stops and says so."""
    check_range(start, stop, parameter)
    span = stop - start
    out = Collector(parameter)
    lam, x = start, np.asarray(x0, float)
    first = newton(fun, x, lam, x_scale=x_scale, f_scale=f_scale, settings=settings)
    out.steps += 1
    if not first.converged:
        out.failed = (lam, first.x)
        return out.finish("stopped", f"no solution at {parameter} = {lam:.6g}: {first.reason}")
    out.add(lam, first)
    if progress:
        progress(len(out), lam, first.iterations)
    step = settings.step
    try:
        return _natural_steps(fun, out, lam, start, stop, span, step, x_scale, f_scale,
                              settings, progress, guesses, parameter)
    except KeyboardInterrupt:
        return out.finish("interrupted", f"interrupted by the user after {parameter} = "
                          f"{out.values[-1]:.6g}")


def _natural_steps(fun, out, lam, start, stop, span, step, x_scale, f_scale, settings,
                   progress, guesses, parameter):
    far = None  # (value, solution) Newton found far from the predictor, kept in case
    ahead = stop  # the nearest value ahead where a step failed (a fold lies before it)
    while (lam - stop) * np.sign(span) < 0 and len(out) < settings.max_points:
        # no step past a value that failed: towards a fold, halving brackets it
        step_now = min(step, abs(ahead - lam) / abs(span))
        new = lam + np.sign(span) * step_now * abs(span)
        pred = out.extrapolate(new)
        r = newton(fun, pred, new, x_scale=x_scale, f_scale=f_scale, settings=settings,
                   stall=STALL)
        out.steps += 1
        if not r.converged:  # past a bend the secant points off the branch
            r = newton(fun, out.xs[-1], new, x_scale=x_scale, f_scale=f_scale,
                       settings=settings, stall=STALL)
            out.steps += 1
        if r.converged and _off_branch(out, r.x, pred, new, x_scale, span):
            # another branch past a fold, or this one past a sharp kink: shorter steps tell
            far = (new, r)
            r = dataclasses.replace(r, converged=False, reason=(
                "Newton converged far from the predictor (on another branch?)"))
        if r.converged:
            lam, far = new, None
            ahead = stop if (ahead - new) * np.sign(span) <= 1e-12 * abs(span) else ahead
            out.add(lam, r)
            if progress:
                progress(len(out), lam, r.iterations)
            step = min(settings.step, step_now * 2)
            continue
        step, ahead = step_now / 2, new
        out.failed = (new, r.x)
        if step >= settings.min_step:
            continue
        # the branch ends or bends sharply within min_step: a fold, a kink (a contact
        # changing state all at once), or the end of the solution set
        target = lam + np.sign(span) * min(settings.step, abs(stop - lam) / abs(span)) * abs(span)
        landed, turned = _detour(fun, out, target, span, x_scale, f_scale, settings)
        if landed is None and far is not None:
            # the branch could not be followed round the bend, but Newton found a solution
            # just past it: kept as before, not claimed as a jump
            (target, landed), turned = far, False
        if landed is None:
            landed = _from_guesses(fun, out, target, x_scale, f_scale, settings, guesses)
            turned = True  # the branch ended before: a solution elsewhere is another one
        if landed is None:
            return out.finish(
                "stopped",
                f"stopped at {parameter} = {new:.6g} (last converged {lam:.6g}): "
                f"{r.reason}; the branch ends within min_step = {settings.min_step:g} of it "
                f"and no other solution was found at {parameter} = {target:.6g} (neither "
                "along the branch past the fold nor from the linear guesses): the end of "
                "the solution set, or a branch these solver settings cannot follow")
        if turned:
            out.jumps.append((len(out) - 1, len(out)))
        lam, step, far, ahead = target, settings.step, None, stop
        out.add(lam, landed)
        if progress:
            progress(len(out), lam, landed.iterations)
    if len(out) >= settings.max_points and (lam - stop) * np.sign(span) < 0:
        return out.finish("stopped", f"max_points = {settings.max_points} reached at {lam:.6g}")
    jumps = "; ".join(f"jumped at the fold at {parameter} = {out.values[i]:.6g} to the other "
                      f"branch at {out.values[j]:.6g}" for i, j in out.jumps)
    return out.finish("complete", jumps)


#: A natural step's solution may lie on another branch when Newton moved it more than FAR
#: times the predictor's own step from the last point (both in the scaled metric): the step
#: is then halved. The secant's error shrinks with the step squared on a smooth branch (the
#: ratio halves and the point is accepted), and with the step across a kink (the branch is
#: followed round it by the detour), while another branch stays O(1) away however short
#: the step.
FAR = 3.0


def _off_branch(out, x, pred, lam, x_scale, span) -> bool:
    """True when the solution ``x`` at ``lam`` is far from the secant predictor ``pred``
    (see FAR); never for the second point or the first after a jump, which have no secant
    to go by."""
    if len(out) < 2 or out.jumped():
        return False

    def rms(v):
        return float(np.sqrt(np.mean((v / x_scale) ** 2))) if v.size else 0.0

    step = rms(pred - out.xs[-1]) + abs(lam - out.values[-1]) / abs(span)
    return rms(x - pred) > FAR * step


#: Most arclength points a jump's detour takes (round the fold, back along the branch
#: between the folds and round the next one) before it gives up.
DETOUR_POINTS = 500


def _from_guesses(fun, out, target, x_scale, f_scale, settings, guesses):
    """The first of the caller's guesses at ``target`` that Newton turns into a solution,
    or None."""
    for guess in (list(guesses(target)) if guesses else []):
        r = newton(fun, guess, target, x_scale=x_scale, f_scale=f_scale, settings=settings)
        out.steps += 1
        if r.converged:
            return r
    return None


def _detour(fun, out, target, span, x_scale, f_scale, settings):
    """Follow the branch from the sweep's last point by pseudo-arclength (in the sweep's
    metric: unknowns by ``x_scale`` rms, parameter by ``|span|``) until the parameter passes
    ``target``, crossing corners and leaping cusps as :func:`arclength` does; Newton at
    ``target`` from the chord there. Returns (NewtonResult or None, turned): ``turned`` when
    the parameter went back on the way (a fold passed: the landing point lies on another
    branch of the sweep's). The detour turns back at most half the sweep's span and stops
    after DETOUR_POINTS points."""
    x, lam = out.xs[-1], out.values[-1]
    direction, lam_scale = np.sign(span), abs(span)
    rms = rms_norm(x)
    xs = np.broadcast_to(np.asarray(x_scale, float), np.shape(x)) * rms
    previous = None
    if len(out) > 1 and not out.jumped():  # the secant: regular at the fold itself
        previous = np.append((out.xs[-1] - out.xs[-2]) / xs,
                             (out.values[-1] - out.values[-2]) / lam_scale)
        previous /= np.linalg.norm(previous)
    first = branch_tangent(fun, x, lam, xs, lam_scale, f_scale, previous, direction)
    if first is None:
        return None, False
    tangent, orientation = first  # the branch's orientation: det [J dR; t] keeps its sign
    # (arclength's corners and leaps: the fold of a contact problem is often a corner)
    walked = walk_to(fun, x, lam, tangent, orientation, target, lam_scale=lam_scale, xs=xs,
                     f_scale=f_scale, settings=dataclasses.replace(
                         settings, max_points=DETOUR_POINTS))
    out.steps += walked.steps
    turned = bool(np.any(np.diff(np.append(lam, walked.values)) * direction < 0))
    if walked.status != "complete":
        return None, turned
    return NewtonResult(walked.x[-1], True, int(walked.iterations[-1]),
                        float(walked.residuals[-1])), turned


#: Halvings of a segment before :func:`solutions_at` gives up on it: 2^-8 of its length is
#: below any chord a continuation accepts, where the secant guess is good.
SEGMENT_HALVINGS = 8


@dataclass
class _Segment:
    """A chord of a branch in the scaled arclength metric: end points (n + 1,), the
    halvings that made it, whether it is part of the branch (a natural sweep's jump is not)
    and whether its search is over."""

    a: np.ndarray
    b: np.ndarray
    depth: int = 0
    real: bool = True
    done: bool = False


def solutions_at(
    fun: Problem,
    values: np.ndarray,
    x: np.ndarray,
    target: float,
    *,
    x_scale: float | np.ndarray,
    f_scale: float,
    settings: Settings = DEFAULT,
    jumps: Sequence[int] = (),
) -> list[NewtonResult]:
    """Every solution at parameter ``target`` of the branch through the computed points
    (``values`` (n,), ``x`` (n, n_unknowns)), one per segment whose ends bracket it; segment
    i (points i, i + 1) with i in ``jumps`` is no part of the branch. In the order found.

    Newton at ``target`` from a bracketing segment's secant guess; the solution is the
    segment's when it is new and nearer to this segment than to any other (in the
    arclength metric of :func:`arclength`, the branch's parameter span as its scale).
    Otherwise (a long chord across a fold, where the guess lands on another part of the
    branch) the segment is halved by a pseudo-arclength corrector on the plane normal to
    the chord through its middle, and its halves are searched in the next round, at most
    SEGMENT_HALVINGS deep: near a turning point, where two solutions at ``target`` lie
    close, the halving goes on until the segments separate them."""
    lam_scale = float(np.ptp(values)) or 1.0
    xs = np.broadcast_to(np.asarray(x_scale, float), np.shape(x[0])) * rms_norm(x[0])
    points = [np.append(xi / xs, li / lam_scale) for li, xi in zip(values, x, strict=True)]
    # a point at the target ends one segment's bracket and starts the next one's: the first
    # segment holds it
    off_branch = set(jumps)
    segments = [_Segment(p, q, real=i not in off_branch, done=i > 0 and values[i] == target)
                for i, (p, q) in enumerate(zip(points[:-1], points[1:], strict=False))]
    found: list[NewtonResult] = []

    def brackets(seg: _Segment) -> bool:
        return (seg.a[-1] * lam_scale - target) * (seg.b[-1] * lam_scale - target) <= 0

    def distances(y: np.ndarray) -> np.ndarray:
        a = np.array([seg.a for seg in segments])
        d = np.array([seg.b for seg in segments]) - a
        along = np.clip(np.einsum("ij,ij->i", y - a, d)
                        / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0.0, 1.0)
        out = np.linalg.norm(a + along[:, None] * d - y, axis=1)
        out[[not seg.real for seg in segments]] = np.inf
        return out

    while True:
        todo = [seg for seg in segments if seg.real and not seg.done and brackets(seg)]
        if not todo:
            return found
        for seg in todo:
            lam_a, lam_b = seg.a[-1] * lam_scale, seg.b[-1] * lam_scale
            t = 0.0 if lam_a == lam_b else (target - lam_a) / (lam_b - lam_a)
            r = newton(fun, (seg.a + t * (seg.b - seg.a))[:-1] * xs, target, x_scale=x_scale,
                       f_scale=f_scale, settings=settings)
            if r.converged and all(not same_solution(r.x, f.x, x_scale) for f in found):
                nearest = segments[int(np.argmin(distances(np.append(r.x / xs,
                                                                     target / lam_scale))))]
                if nearest is seg:
                    found.append(r)
                    seg.done = True
                    continue
            seg.done = True  # halved below, or given up
            chord = seg.b - seg.a
            length = float(np.linalg.norm(chord))
            if seg.depth == SEGMENT_HALVINGS or length == 0.0:
                continue
            ok, middle, *_ = corrector(fun, 0.5 * (seg.a + seg.b), chord / length, xs,
                                      lam_scale, f_scale, settings)
            if ok:
                k = next(i for i, s in enumerate(segments) if s is seg)
                segments[k:k + 1] = [_Segment(seg.a, middle, seg.depth + 1),
                                     _Segment(middle, seg.b, seg.depth + 1)]


def on_chord(fun: Problem, a: tuple[float, np.ndarray], b: tuple[float, np.ndarray],
             fraction: float, *, x_scale: float | np.ndarray, lam_scale: float,
             f_scale: float, settings: Settings = DEFAULT
             ) -> tuple[float, NewtonResult] | None:
    """The branch's point between two of its points ``a``, ``b`` = (lam, x): the
    pseudo-arclength corrector on the plane normal to their chord through the point at
    ``fraction`` (0..1) of it, in the metric of :func:`arclength` (unknowns by ``x_scale``
    rms, the parameter by ``lam_scale``). (lam, NewtonResult) or None if it fails."""
    xs = np.broadcast_to(np.asarray(x_scale, float), np.shape(a[1])) * rms_norm(a[1])
    ya, yb = (np.append(x / xs, lam / lam_scale) for lam, x in (a, b))
    chord = yb - ya
    length = float(np.linalg.norm(chord))
    if length == 0.0:
        return None
    ok, y, its, res, _ = corrector(fun, ya + fraction * chord, chord / length, xs, lam_scale,
                                  f_scale, settings)
    if not ok:
        return None
    return float(y[-1] * lam_scale), NewtonResult(y[:-1] * xs, True, its, res)
