"""Newton's method at a fixed parameter and on the bordered system of arclength
continuation (Firrone & Zucca appendix, eqs. 55-56): the corrector, the branch tangent and
its orientation, the step adaptation.

The problem is a callable ``fun(x, lam, jacobian) -> (R, J, R_lam)``: the residual ``R``
(n,), its Jacobian ``J = dR/dx`` ((n, n) dense, or a structured
:class:`~microslip.solve.jacobian.BalanceJacobian` solved by its own method) and
``R_lam = dR/dlam`` (n,), in physical units.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from .branch import NewtonResult
from .jacobian import RTOL, STRUCTURED, BalanceJacobian, BorderedJacobian, lu_sign

Problem = Callable[[np.ndarray, float, bool], tuple[np.ndarray, np.ndarray, np.ndarray]]


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


#: A Newton solve that its caller can do without (a natural step, arclength's landing on
#: the end value: both halve their step; a corner's crossing: the next is longer) gives up
#: once its best ||R|| has not halved in STALL iterations (:func:`newton`'s ``stall``): a
#: step that fails is nearly always at a fold, where Newton cannot converge however long it
#: runs. Traced on a 48-blade mistuned disk at 10 N (its dampers lifting off and slipping;
#: 265 natural-step Newton solves): the 46 that failed ran all 25 iterations, 55 % of the
#: sweep's; 10 of the 219 that converged took 13-20. A fold's detour on the disk at 3 N
#: spent ten minutes in failed landings and crossings of 25 iterations each.
STALL = 6


def newton(
    fun: Problem,
    x0: np.ndarray,
    lam: float,
    *,
    x_scale: float | np.ndarray = 1.0,
    f_scale: float = 1.0,
    settings: Settings = DEFAULT,
    stall: int | None = None,
) -> NewtonResult:
    """Damped Newton iterations on ``R(x, lam) = 0`` at fixed ``lam``. ``stall``: give up
    once the best ||R|| of the last ``stall`` iterations is not half the best before them
    (Newton cycling between contact states: where the caller can shorten its step, that
    costs less than the rest of ``max_iter``)."""
    x = np.array(x0, dtype=float)
    R, J, _ = fun(x, lam, True)
    res = _norm(R, f_scale)
    history: list[float] = []
    merit = None  # the last iterate's ||R||_2
    for it in range(settings.max_iter + 1):
        if not np.isfinite(res):
            return NewtonResult(x, False, it, res, "residual is NaN or Inf")
        if res <= settings.tol:
            return NewtonResult(x, True, it, res)
        if it == settings.max_iter:
            break
        history.append(res)
        if stall and _stalled(history, stall):
            return NewtonResult(x, False, it, res, (
                f"stalled: ||R|| not halved in {stall} iterations (best "
                f"{min(history):.3g} * f_scale after {it})"))
        merit, last = float(np.linalg.norm(R)), merit
        try:
            eta = forcing(merit, last, settings.tol * f_scale)
            dx = _capped(-_solve(J, R, rtol=eta), x_scale)
        except (np.linalg.LinAlgError, ValueError) as err:
            return NewtonResult(x, False, it, res, f"singular Jacobian ({err})")
        x, R, J = _damped(fun, x, dx, lam, R)
        res = _norm(R, f_scale)
    return NewtonResult(
        x, False, settings.max_iter, res,
        f"no convergence in {settings.max_iter} iterations (||R|| = {res:.3g} * f_scale)",
    )


#: Inexact Newton (Eisenstat & Walker 1996): a structured Jacobian's step is solved by
#: GMRES only as far as the iteration needs, never looser than ETA_MAX (Newton's
#: convergence then stays nearly quadratic) nor tighter than the GMRES default.
ETA_MAX = 1e-3


def forcing(merit: float, last: float | None, tolerance: float) -> float:
    """GMRES's relative tolerance for a Newton step at ||R||_2 = ``merit`` (``last``: the
    iterate before's, None at the first): the loosest of (a) a step whose linear residual
    is a tenth of the convergence ``tolerance`` (max norm <= 2-norm: the next iterate can
    converge) and (b) Eisenstat & Walker's choice 2, 0.9 (merit / last)^2 (far from the
    solution the quadratic term dominates what a tighter solve would remove)."""
    need = 0.1 * tolerance / merit if merit > 0 else 1.0
    walker = 0.9 * (merit / last) ** 2 if last else 0.0
    return float(np.clip(max(need, walker), RTOL, ETA_MAX))


def _stalled(history: list[float], window: int) -> bool:
    """Whether the best of the last ``window`` residual norms is not half the best of
    those before them."""
    return (len(history) > window
            and min(history[-window:]) > 0.5 * min(history[:-window]))


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


def _solve(J: np.ndarray | BalanceJacobian | BorderedJacobian, R: np.ndarray,
           keep: list | None = None, rtol: float = RTOL) -> np.ndarray:
    """J^-1 R by LU (a structured J: its own solve, to ``rtol``); the LU factors are put in
    ``keep`` if given (for reuse)."""
    if isinstance(J, STRUCTURED):
        return J.solve(R, rtol)
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


def rms_norm(x: np.ndarray) -> float:
    """sqrt(n): the arc metric's x_scale is the unknowns' scale times it (their rms)."""
    return float(np.sqrt(max(np.size(x), 1)))


#: A corrector that lands further than this many steps from its predictor has left for
#: another branch.
ON_BRANCH = 10.0


def adapted_step(h: float, t_new: np.ndarray, tangent: np.ndarray, its: int,
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


#: From this many unknowns on, the tangent after a corrector reuses the corrector's last
#: factorization (of the bordered Jacobian one iterate before convergence) instead of a new
#: one: a factorization then costs far more than the rest of a step (1296 unknowns: 54 ms
#: against ~15 ms), and a predictor direction needs no more accuracy than that.
REUSE_FACTORS = 500


def branch_tangent(fun, x, lam, xs, lam_scale, f_scale, previous, direction, jac=None):
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
    if isinstance(J, STRUCTURED):
        return _structured_tangent(J, dR, xs, lam_scale, f_scale, previous, direction)
    if previous is not None and factors and factors[0] and n >= REUSE_FACTORS:
        rhs = np.zeros(n + 1)
        rhs[n] = 1.0
        lu, piv = factors[0][0]
        t = sla.lu_solve((lu, piv), rhs, check_finite=False)
        if np.all(np.isfinite(t)) and np.linalg.norm(t) > 0:
            return t / np.linalg.norm(t), lu_sign(lu, piv)  # previous . t = 1 > 0
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
        return t / np.linalg.norm(t), lu_sign(*keep[0])  # previous . t = 1 > 0
    with warnings.catch_warnings():  # J is regular here (z was solved from it)
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        lu, piv = sla.lu_factor(A, check_finite=False)
    return t / np.linalg.norm(t), lu_sign(lu, piv)


def _structured_tangent(J, dR, xs, lam_scale, f_scale, previous, direction):
    """:func:`branch_tangent` with a structured Jacobian: its bordered solve and determinant
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
        sign = J.bordered_sign(dR * lam_scale, row[:n] * (f_scale / xs), row[n] * f_scale)
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not (np.all(np.isfinite(t)) and np.linalg.norm(t) > 0 and sign != 0):
        return None
    return t / np.linalg.norm(t), sign


def _bordered(J, dR, row, xs, lam_scale, f_scale, rhs, keep=None) -> np.ndarray:
    """z of [J diag(xs) / f_scale, dR lam_scale / f_scale; row] z = rhs (the scaled
    bordered system), the LU factors of a dense one put in ``keep``."""
    n = xs.size
    if isinstance(J, STRUCTURED):  # in u = xs z[:n], the unscaled unknowns
        # the arc equation in force units too, so that GMRES's one residual norm weighs
        # both rows as the dense path's scaling does
        z = J.bordered_solve(dR * lam_scale, row[:n] * (f_scale / xs), row[n] * f_scale,
                             rhs * f_scale)
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


def corrector(fun, pred, tangent, xs, lam_scale, f_scale, settings):
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
