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
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from microslip.pipeline.solve.jacobian import BalanceJacobian

Problem = Callable[[np.ndarray, float, bool], tuple[np.ndarray, np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class NewtonResult:
    x: np.ndarray
    converged: bool
    iterations: int
    residual: float  # ||R||_inf / f_scale at x
    reason: str = ""


@dataclass
class Branch:
    """A computed solution branch: one row per converged point."""

    parameter: str
    values: np.ndarray  # (n_points,) parameter value
    x: np.ndarray  # (n_points, n_unknowns)
    residuals: np.ndarray  # (n_points,) scaled residual norm
    iterations: np.ndarray  # (n_points,) Newton iterations
    turning_points: list[int] = field(default_factory=list)  # where the parameter reverses
    status: str = "complete"  # "complete", "stopped" or "interrupted"
    message: str = ""
    steps: int = 0  # predictor-corrector attempts, including rejected ones
    failed: tuple[float, np.ndarray] | None = None  # (lam, x) of the last failed attempt
    #: natural sweeps: (i, i + 1) where point i + 1 lies on another branch than point i
    #: (a jump at the fold next to point i)
    jumps: list[tuple[int, int]] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        return self.status == "complete"

    def __len__(self) -> int:
        return self.values.size


@dataclass(frozen=True)
class Settings:
    """Solver knobs (each one's speed/accuracy trade is shown by ``microslip bench core``).

    tol: converged when ||R||_inf <= tol * f_scale.
    max_iter: Newton iterations per point.
    step: first step, as a fraction of the parameter range (arclength: of the
        scaled arc). min_step / max_step bound the adaptive step (same units).
    target_iter: the arclength step grows below it and shrinks above it.
    max_turn: the arclength step halves where the tangent turns more (rad).
    max_points: stop after this many points (a guard against cycling).
    """

    tol: float = 1e-9
    max_iter: int = 25
    step: float = 0.01
    min_step: float = 1e-6
    max_step: float = 0.05
    target_iter: int = 4
    max_turn: float = 0.15
    max_points: int = 5000
    lower: float = -np.inf  # the parameter's admissible range (e.g. frequency > 0)
    upper: float = np.inf

    def __post_init__(self):
        for name in ("tol", "step", "min_step", "max_step", "max_turn"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"continuation: '{name}' must be > 0, got {v}")
        if self.min_step > self.max_step:
            raise ValueError(
                f"continuation: 'min_step' ({self.min_step}) exceeds 'max_step' ({self.max_step})"
            )
        for name in ("max_iter", "target_iter", "max_points"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ValueError(f"continuation: '{name}' must be an integer >= 1, got {v}")


DEFAULT = Settings()
MAX_CORNERS = 20  # fixed-parameter crossings of a non-smooth branch, per branch
#: After this many correctors missed in a row (the step 2^-6 of what it was), a corner is
#: tried before any shorter step: at a corner no step is short enough, and halving down to
#: min_step costs some 15 more failed correctors each time.
CORNER_MISSES = 6


def newton(
    fun: Problem,
    x0: np.ndarray,
    lam: float,
    *,
    x_scale: float | np.ndarray = 1.0,
    f_scale: float = 1.0,
    settings: Settings = DEFAULT,
) -> NewtonResult:
    """Damped Newton iterations on ``R(x, lam) = 0`` at fixed ``lam``."""
    x = np.array(x0, dtype=float)
    R, J, _ = fun(x, lam, True)
    res = _norm(R, f_scale)
    for it in range(settings.max_iter + 1):
        if not np.isfinite(res):
            return NewtonResult(x, False, it, res, "residual is NaN or Inf")
        if res <= settings.tol:
            return NewtonResult(x, True, it, res)
        if it == settings.max_iter:
            break
        try:
            dx = _capped(-_solve(J, R), x_scale)
        except (np.linalg.LinAlgError, ValueError) as err:
            return NewtonResult(x, False, it, res, f"singular Jacobian ({err})")
        x, R, J = _damped(fun, x, dx, lam, R)
        res = _norm(R, f_scale)
    return NewtonResult(
        x, False, settings.max_iter, res,
        f"no convergence in {settings.max_iter} iterations (||R|| = {res:.3g} * f_scale)",
    )


MAX_STEP = 1e4  # largest Newton step, in units of x_scale per unknown


def _capped(dx: np.ndarray, x_scale: float | np.ndarray) -> np.ndarray:
    """The Newton step shortened (direction kept) to at most MAX_STEP x_scale per unknown.

    A weakly determined direction (a contact slipping statically: its force no longer
    depends on how far it has slid) makes the Jacobian nearly singular there, and a full
    step can throw the solution metres away along it, where the friction directions, and so
    everything else, are lost; the residual hardly cares, so the line search would take it.
    """
    big = float(np.max(np.abs(dx) / x_scale)) if dx.size else 0.0
    return dx if big <= MAX_STEP else dx * (MAX_STEP / big)


def _damped(fun, x, dx, lam, R0):
    """Backtracking: halve the step until ||R||_2 decreases (at most 6 times).

    The 2-norm, not the convergence test's max-norm, because the Newton step
    is a descent direction of ||R||_2^2 wherever R is differentiable; on the
    piecewise-smooth friction residual the max-norm can stall at a kink."""
    best = None
    alpha = 1.0
    merit0 = np.linalg.norm(R0)
    for _ in range(7):
        xt = x + alpha * dx
        R, J, _ = fun(xt, lam, True)
        merit = np.linalg.norm(R)
        if best is None or (np.isfinite(merit) and merit < best[3]):
            best = (xt, R, J, merit)
        if np.isfinite(merit) and merit < merit0:
            break
        alpha *= 0.5
    return best[:3]


def _norm(R: np.ndarray, f_scale: float) -> float:
    return float(np.max(np.abs(R))) / f_scale if R.size else 0.0


def _solve(J: np.ndarray | BalanceJacobian, R: np.ndarray, keep: list | None = None
           ) -> np.ndarray:
    """J^-1 R by LU (a structured J: its own solve); the LU factors are put in ``keep`` if
    given (for reuse)."""
    if isinstance(J, BalanceJacobian):
        return J.solve(R)
    if not np.all(np.isfinite(J)):
        raise ValueError("Jacobian has NaN or Inf")
    with warnings.catch_warnings():  # a zero pivot is reported below, as an error
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        lu, piv = sla.lu_factor(J, check_finite=False)
    if np.any(np.diag(lu) == 0):
        raise np.linalg.LinAlgError("zero pivot")
    if keep is not None:
        keep[:] = [(lu, piv)]
    return sla.lu_solve((lu, piv), R, check_finite=False)


#: From this many unknowns on, the tangent after a corrector reuses the corrector's last
#: factorization (of the bordered Jacobian one iterate before convergence) instead of a new
#: one: a factorization then costs far more than the rest of a step (1296 unknowns: 54 ms
#: against ~15 ms), and a predictor direction needs no more accuracy than that.
REUSE_FACTORS = 500


def check_range(start: float, stop: float, name: str) -> None:
    """ValueError unless the range of parameter ``name`` is finite and not empty."""
    if not (np.isfinite(start) and np.isfinite(stop)):
        raise ValueError(f"continuation: range of '{name}' must be finite, got {start}..{stop}")
    if start == stop:
        raise ValueError(
            f"continuation: range of '{name}' has zero length ({start} to {stop}); "
            "give start != stop"
        )


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
    out = _Collector(parameter)
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
    while (lam - stop) * np.sign(span) < 0 and len(out) < settings.max_points:
        step_now = min(step, abs(stop - lam) / abs(span))
        new = lam + np.sign(span) * step_now * abs(span)
        pred = out.extrapolate(new)
        r = newton(fun, pred, new, x_scale=x_scale, f_scale=f_scale, settings=settings)
        out.steps += 1
        if not r.converged:  # past a bend the secant points off the branch
            r = newton(fun, out.xs[-1], new, x_scale=x_scale, f_scale=f_scale,
                       settings=settings)
            out.steps += 1
        if r.converged and _off_branch(out, r.x, pred, new, x_scale, span):
            # another branch past a fold, or this one past a sharp kink: shorter steps tell
            far = (new, r)
            r = dataclasses.replace(r, converged=False, reason=(
                "Newton converged far from the predictor (on another branch?)"))
        if r.converged:
            lam, far = new, None
            out.add(lam, r)
            if progress:
                progress(len(out), lam, r.iterations)
            step = min(settings.step, step * 2)
            continue
        step /= 2
        out.failed = (new, r.x)
        if step >= settings.min_step:
            continue
        # the branch ends or bends sharply within min_step: a fold, a kink (a contact
        # changing state all at once), or the end of the solution set
        target = lam + np.sign(span) * min(settings.step, abs(stop - lam) / abs(span)) * abs(span)
        landed, turned = _detour(fun, out, target, start, stop, span, x_scale, f_scale,
                                 settings)
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
        lam, step, far = target, settings.step, None
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
#: A corrector that lands further than this many steps from its predictor has left for
#: another branch.
ON_BRANCH = 10.0


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


def _detour(fun, out, target, start, stop, span, x_scale, f_scale, settings):
    """Follow the branch from the sweep's last point by pseudo-arclength (in the sweep's
    metric: unknowns by ``x_scale`` rms, parameter by ``|span|``) until the parameter passes
    ``target``; Newton at ``target`` from the chord there. Returns (NewtonResult or None,
    turned): ``turned`` when the parameter went back on the way (a fold passed: the landing
    point lies on another branch of the sweep's). The detour keeps within one span of the
    sweep's range and stops after DETOUR_POINTS points."""
    x, lam = out.xs[-1], out.values[-1]
    direction, lam_scale = np.sign(span), abs(span)
    rms = _rms(x)
    xs = np.broadcast_to(np.asarray(x_scale, float), np.shape(x)) * rms
    previous = None
    if len(out) > 1 and not out.jumped():  # the secant: regular at the fold itself
        previous = np.append((out.xs[-1] - out.xs[-2]) / xs,
                             (out.values[-1] - out.values[-2]) / lam_scale)
        previous /= np.linalg.norm(previous)
    first = _tangent(fun, x, lam, xs, lam_scale, f_scale, previous, direction)
    if first is None:
        return None, False
    tangent, orientation = first  # the branch's orientation: det [J dR; t] keeps its sign
    lo, hi = min(start, stop) - lam_scale, max(start, stop) + lam_scale
    h, turned, points = settings.step, False, 0
    while points < DETOUR_POINTS:
        pred = np.append(x / xs, lam / lam_scale) + h * tangent
        ok, y, its, _, info = _correct(fun, pred, tangent, xs, lam_scale, f_scale, settings)
        out.steps += 1
        if not ok or np.linalg.norm(y - pred) > ON_BRANCH * h:
            h /= 2
            if h < settings.min_step:
                return None, turned
            continue
        points += 1
        x_new, lam_new = y[:-1] * xs, y[-1] * lam_scale
        turned = turned or (lam_new - lam) * direction < 0
        if (lam_new - target) * direction >= 0:  # passed the target: land there
            chord = x + (target - lam) / (lam_new - lam) * (x_new - x)
            r = newton(fun, chord, target, x_scale=xs / rms, f_scale=f_scale,
                       settings=settings)
            out.steps += 1
            return (r if r.converged else None), turned
        if not (lo <= lam_new <= hi and settings.lower < lam_new < settings.upper):
            return None, turned
        new_tangent = _tangent(fun, x_new, lam_new, xs, lam_scale, f_scale, tangent,
                               direction, info)
        if new_tangent is None:
            return None, turned
        t_new = new_tangent[0] * new_tangent[1] * orientation
        h = _adapted_step(h, t_new, tangent, its, settings)
        x, lam, tangent = x_new, lam_new, t_new
    return None, turned


def _adapted_step(h: float, t_new: np.ndarray, tangent: np.ndarray, its: int,
                  settings: Settings) -> float:
    """The next arclength step after one of ``h``: adapted to how fast the branch turns
    (tangent ``tangent`` -> ``t_new``) and to the corrector's effort (``its`` iterations)."""
    turn = np.arccos(np.clip(t_new @ tangent, -1.0, 1.0))
    if turn > settings.max_turn:
        return max(h * 0.5, settings.min_step)
    if its <= settings.target_iter - 1:
        return min(h * 1.5, settings.max_step)
    if its > settings.target_iter + 2:
        return max(h * 0.6, settings.min_step)
    return h


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
    rms = _rms(x0)
    xs = np.broadcast_to(np.asarray(x_scale, float), np.shape(x0)) * rms
    out = _Collector(parameter)
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
    first_tangent = _tangent(fun, x, lam, xs, lam_scale, f_scale, None, direction)
    if first_tangent is None:
        return out.finish("stopped", f"singular Jacobian at {parameter} = {lam:.6g}")
    try:
        return _arclength_steps(fun, out, x, lam, first_tangent, xs, lam_scale, direction,
                                start, stop, f_scale, settings, progress, parameter, watch)
    except KeyboardInterrupt:
        return out.finish("interrupted", f"interrupted by the user after {parameter} = "
                          f"{out.values[-1]:.6g}")


def _rms(x: np.ndarray) -> float:
    """sqrt(n): the arc metric's x_scale is the unknowns' scale times it (their rms)."""
    return float(np.sqrt(max(np.size(x), 1)))


def _arclength_steps(fun, out, x, lam, first_tangent, xs, lam_scale, direction, start, stop,
                     f_scale, settings, progress, parameter, watch):
    tangent, orientation = first_tangent
    rms = _rms(x)
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
        ok, y_new, its, res, info = _correct(fun, pred, tangent, xs, lam_scale, f_scale,
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
                crossed_tangent = _tangent(fun, r.x, lam_c, xs, lam_scale, f_scale, tangent,
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
        new_tangent = _tangent(fun, x_new, lam_new, xs, lam_scale, f_scale, tangent,
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
        h = _adapted_step(h, t_new, tangent, its, settings)
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


def _stalled(out: _Collector, lam_scale: float) -> str:
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
        r = newton(fun, x, lam_c, x_scale=xs / _rms(x), f_scale=f_scale, settings=settings)
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
        ok, y, its, res, info = _correct(fun, pred, tangent, xs, lam_scale, f_scale, settings)
        onward = abs(tangent[-1]) < 1e-3 or (y[-1] - y0[-1]) * tangent[-1] > 0
        if ok and onward and np.linalg.norm(y - pred) <= ON_BRANCH * h:
            return (y, its, res, info, h), tries
    return None, tries


def _lu_sign(lu: np.ndarray, piv: np.ndarray) -> float:
    """Sign of the determinant of the matrix that LAPACK factored into (lu, piv)."""
    swaps = np.count_nonzero(piv != np.arange(piv.size))
    return float(np.prod(np.sign(np.diag(lu)))) * (-1.0) ** swaps


def _tangent(fun, x, lam, xs, lam_scale, f_scale, previous, direction, jac=None):
    """(t, s): the unit tangent of the scaled branch and s = sign det [J dR; t] for it.

    t is oriented along ``previous`` (or towards increasing progress at the first
    point); the caller fixes the orientation by s, which stays constant along a branch
    and flips t at a fold only (Allgower & Georg): a Jacobian that jumps at a
    stick/slip kink can turn the dot product with the previous tangent negative, and
    the branch would then retrace itself. ``jac``: (J, dR, factors) at (x, lam) if
    already known; for the bordered row r, det [J dR; t] = det [J dR; r] (r . t) / |t|
    gives s from the factors of any bordered matrix."""
    J, dR, *factors = jac if jac is not None else fun(x, lam, True)[1:]
    n = x.size
    if isinstance(J, BalanceJacobian):
        return _structured_tangent(J, dR, xs, lam_scale, f_scale, previous, direction)
    if previous is not None and factors and factors[0] and n >= REUSE_FACTORS:
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        lu, piv = factors[0][0]
        t = sla.lu_solve((lu, piv), rhs, check_finite=False)
        if np.all(np.isfinite(t)) and np.linalg.norm(t) > 0:
            return t / np.linalg.norm(t), _lu_sign(lu, piv)  # previous . t = 1 > 0
    Js = J * xs[None, :] / f_scale
    dRs = dR * lam_scale / f_scale
    A = np.zeros((n + 1, n + 1))
    A[:n, :n], A[:n, n] = Js, dRs
    if previous is None:
        try:
            z = _solve(Js, -dRs)
        except (np.linalg.LinAlgError, ValueError):
            return None
        t = np.append(z, 1.0) * direction
        A[n] = t
    else:
        A[n] = previous
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        keep: list = []
        try:
            t = _solve(A, rhs, keep)
        except (np.linalg.LinAlgError, ValueError):
            return None
        return t / np.linalg.norm(t), _lu_sign(*keep[0])  # previous . t = 1 > 0
    with warnings.catch_warnings():  # J is regular here (z was solved from it)
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        lu, piv = sla.lu_factor(A, check_finite=False)
    return t / np.linalg.norm(t), _lu_sign(lu, piv)


def _structured_tangent(J, dR, xs, lam_scale, f_scale, previous, direction):
    """:func:`_tangent` with a structured Jacobian: its bordered solve and determinant
    sign (in the unscaled unknowns; the scalings are positive, so the sign is the same)."""
    n = xs.size
    try:
        if previous is None:
            t = np.append(J.solve(-dR * lam_scale) / xs, 1.0) * direction
            row = t
        else:
            rhs = np.zeros(n + 1)
            rhs[n] = 1.0
            t, row = _bordered(J, dR, previous, xs, lam_scale, f_scale, rhs), previous
        sign = J.bordered_sign(dR * lam_scale, row[:n] / xs, row[n])
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not (np.all(np.isfinite(t)) and np.linalg.norm(t) > 0 and sign != 0):
        return None
    return t / np.linalg.norm(t), sign


def _bordered(J, dR, row, xs, lam_scale, f_scale, rhs, keep=None) -> np.ndarray:
    """z of [J diag(xs) / f_scale, dR lam_scale / f_scale; row] z = rhs (the scaled
    bordered system), the LU factors of a dense one put in ``keep``."""
    n = xs.size
    if isinstance(J, BalanceJacobian):  # in u = xs z[:n], the unscaled unknowns
        z = J.bordered_solve(dR * lam_scale, row[:n] / xs, row[n],
                             np.append(rhs[:n] * f_scale, rhs[n]))
        z[:n] /= xs
        return z
    A = np.empty((n + 1, n + 1))
    A[:n, :n] = J * xs[None, :] / f_scale
    A[:n, n] = dR * lam_scale / f_scale
    A[n] = row
    return _solve(A, rhs, keep)


#: The corrector gives up after CORRECTOR_ITER x target_iter iterations, or when STAGNATION
#: iterations have not halved its merit: on a branch with stick/slip kinks an iterate can
#: sit on a kink between two linear pieces, each pointing Newton at the other, and 25 damped
#: iterations there cost 100 evaluations (20 s on the full-scale blisk); a step half as
#: long almost always converges in 2-4. Not fewer than 6: on the zigzag branch of an
#: undersampled law-B oscillator (tests/test_case.py's run) 4 made the branch turn back.
CORRECTOR_ITER = 3
STAGNATION = 6


def _correct(fun, pred, tangent, xs, lam_scale, f_scale, settings):
    """Newton on [R(y) = 0; t . (y - y_pred) = 0] (Firrone & Zucca eq. 56), damped like
    :func:`newton`: near a stick/slip kink the full step can jump between two
    linear pieces and cycle; halving it until the residual falls breaks that."""

    def evaluate(y):
        x, lam = y[:-1] * xs, y[-1] * lam_scale
        R, J, dR = fun(x, lam, True)
        # 2-norm merit for the line search (see _damped)
        merit = np.hypot(np.linalg.norm(R) / f_scale, tangent @ (y - pred))
        return R, J, dR, merit

    y = pred.copy()
    R, J, dR, merit = evaluate(y)
    factors: list = []  # the last LU of the bordered Jacobian (the tangent may reuse it)
    max_iter = min(settings.max_iter, CORRECTOR_ITER * settings.target_iter)
    merits = [merit]
    for it in range(max_iter + 1):
        res = max(_norm(R, f_scale), abs(tangent @ (y - pred)))
        if not np.isfinite(res):
            return False, y, it, res, "residual is NaN or Inf"
        if res <= settings.tol:
            return True, y, it, res, (J, dR, factors)
        if it == max_iter:
            break
        if it >= STAGNATION and merit > 0.5 * merits[-1 - STAGNATION]:
            return False, y, it, res, (f"no progress in {STAGNATION} iterations "
                                       f"(||R|| = {res:.3g} * f_scale)")
        rhs = np.append(R / f_scale, tangent @ (y - pred))
        try:
            step = -_bordered(J, dR, tangent, xs, lam_scale, f_scale, rhs, factors)
        except (np.linalg.LinAlgError, ValueError) as err:
            return False, y, it, res, f"singular bordered Jacobian ({err})"
        best = None
        alpha = 1.0
        for _ in range(7):
            trial = evaluate(y + alpha * step)
            if best is None or (np.isfinite(trial[3]) and trial[3] < best[1][3]):
                best = (y + alpha * step, trial)
            if np.isfinite(trial[3]) and trial[3] < merit:
                break
            alpha *= 0.5
        y, (R, J, dR, merit) = best
        merits.append(merit)
    return False, y, max_iter, res, f"no convergence (||R|| = {res:.3g} * f_scale)"


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
    xs = np.broadcast_to(np.asarray(x_scale, float), np.shape(x[0])) * _rms(x[0])
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
            ok, middle, *_ = _correct(fun, 0.5 * (seg.a + seg.b), chord / length, xs,
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
    xs = np.broadcast_to(np.asarray(x_scale, float), np.shape(a[1])) * _rms(a[1])
    ya, yb = (np.append(x / xs, lam / lam_scale) for lam, x in (a, b))
    chord = yb - ya
    length = float(np.linalg.norm(chord))
    if length == 0.0:
        return None
    ok, y, its, res, _ = _correct(fun, ya + fraction * chord, chord / length, xs, lam_scale,
                                  f_scale, settings)
    if not ok:
        return None
    return float(y[-1] * lam_scale), NewtonResult(y[:-1] * xs, True, its, res)


#: Two converged solutions nearer than this share of the unknowns' scale are one (Newton
#: stops at a residual of 1e-9 of the force scale by default: its solutions differ less)
SAME_SOLUTION = 1e-6


def same_solution(x: np.ndarray, y: np.ndarray, x_scale: float | np.ndarray) -> bool:
    """Whether two solutions are one: max |x - y| / x_scale below SAME_SOLUTION."""
    return bool(np.max(np.abs(x - y) / x_scale, initial=0.0) <= SAME_SOLUTION)


class _Collector:
    def __init__(self, parameter: str):
        self.parameter = parameter
        self.values: list[float] = []
        self.xs: list[np.ndarray] = []
        self.res: list[float] = []
        self.its: list[int] = []
        self.turning_points: list[int] = []
        self.jumps: list[tuple[int, int]] = []
        self.steps = 0
        self.failed: tuple[float, np.ndarray] | None = None

    def __len__(self) -> int:
        return len(self.values)

    def add(self, lam: float, r: NewtonResult) -> None:
        """Keep a converged point; the one before it is a turning point where the
        parameter's direction reverses there (not where the tangent's parameter component
        changes sign: at a near-vertical rise that flips in pairs while the parameter never
        goes back)."""
        v = self.values
        if len(v) >= 2 and (lam - v[-1]) * (v[-1] - v[-2]) < 0:
            self.turning_points.append(len(v) - 1)
        self.values.append(float(lam))
        self.xs.append(np.array(r.x))
        self.res.append(r.residual)
        self.its.append(r.iterations)

    def extrapolate(self, lam: float) -> np.ndarray:
        """Secant predictor from the last two points (the last one if alone or if a jump
        separates them: they lie on different branches)."""
        if len(self.values) < 2 or self.values[-1] == self.values[-2] or self.jumped():
            return self.xs[-1].copy()
        a = (lam - self.values[-1]) / (self.values[-1] - self.values[-2])
        return self.xs[-1] + a * (self.xs[-1] - self.xs[-2])

    def jumped(self) -> bool:
        """Whether the last point is the landing of a jump (no secant to it)."""
        return bool(self.jumps) and self.jumps[-1][1] == len(self.values) - 1

    def finish(self, status: str, message: str) -> Branch:
        n = self.xs[0].size if self.xs else 0
        return Branch(
            self.parameter,
            np.array(self.values),
            np.array(self.xs).reshape(len(self.xs), n),
            np.array(self.res),
            np.array(self.its, dtype=int),
            list(self.turning_points),
            status,
            message,
            self.steps,
            self.failed,
            list(self.jumps),
        )
