"""A continuation's results: the points of a branch (:class:`Branch`), one solution
(:class:`NewtonResult`), and the bookkeeping the continuations share while they run."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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


def check_range(start: float, stop: float, name: str) -> None:
    """ValueError unless the range of parameter ``name`` is finite and not empty."""
    if not (np.isfinite(start) and np.isfinite(stop)):
        raise ValueError(f"continuation: range of '{name}' must be finite, got {start}..{stop}")
    if start == stop:
        raise ValueError(
            f"continuation: range of '{name}' has zero length ({start} to {stop}); "
            "give start != stop"
        )


#: Two converged solutions nearer than this share of the unknowns' scale are one (Newton
#: stops at a residual of 1e-9 of the force scale by default: its solutions differ less)
SAME_SOLUTION = 1e-6


def same_solution(x: np.ndarray, y: np.ndarray, x_scale: float | np.ndarray) -> bool:
    """Whether two solutions are one: max |x - y| / x_scale below SAME_SOLUTION."""
    return bool(np.max(np.abs(x - y) / x_scale, initial=0.0) <= SAME_SOLUTION)


class Collector:
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
