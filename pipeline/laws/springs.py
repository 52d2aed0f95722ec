"""The benchmark nonlinearities beside friction: elastic springs whose force is a function of
one relative displacement u, evaluated by alternating frequency/time (AFT) with their exact
Jacobian.

* ``law = "polynomial"``: ``f(u) = sum_p c_p u^p`` for p = 1..n (``coefficients`` [c_1, ...,
  c_n], N/m^p): the cubic spring of the Duffing oscillator ``x'' + 2 zeta x' + x + gamma x^3
  = P cos w t`` is ``coefficients = [0.0, 0.0, gamma]`` beside the linear model.
* ``law = "unilateral"``: ``f(u) = kn max(u - gap, 0)`` (``kn`` N/m, ``gap`` m; a negative
  gap is a preload): contact without friction, the element of impacting and rubbing models.

The force resists the relative motion (on the DOFs ``-B^T f``), as the friction laws'.
Samples: u^n has harmonics up to n H, so ``n_samples > (n + 1) H`` keeps the polynomial's
first H harmonics free of aliasing (exact); the unilateral spring's kink is resolved to the
sampling, as friction's stick-slip transitions are.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from microslip.fourier import Harmonics

from .coulomb import ContactResponse
from .states import OPEN, PARTIAL_LIFTOFF, STICK


@dataclass(frozen=True, eq=False)
class SpringSet:
    """P spring points of one law (a :class:`.law.ContactSet`): one component each.

    law: "polynomial" or "unilateral"; coefficients: (P, n) c_1..c_n [N/m^p] (polynomial);
    kn: (P,) [N/m], gap: (P,) [m] (unilateral)."""

    law: str
    coefficients: np.ndarray | None = None
    kn: np.ndarray | None = None
    gap: np.ndarray | None = None
    # what the results and the friction-specific code ask of a contact set
    coupled = False
    variable_normal = False
    dim = 0

    @property
    def size(self) -> int:
        return len(self.coefficients if self.law == "polynomial" else self.kn)

    @property
    def n_components(self) -> int:
        return 1

    @property
    def n0(self) -> np.ndarray:
        return np.zeros(self.size)

    def force(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(f, df/du) at displacement samples u (P, ns) [m] -> [N], [N/m]."""
        if self.law == "polynomial":
            c = self.coefficients  # (P, n): f = sum_p c_p u^p (Horner on f / u and f')
            quotient, df = np.zeros_like(u), np.zeros_like(u)
            for p in range(c.shape[1], 0, -1):
                quotient = quotient * u + c[:, p - 1, None]
                df = df * u + p * c[:, p - 1, None]
            return quotient * u, df
        closing = u - self.gap[:, None]
        on = closing > 0.0
        return np.where(on, self.kn[:, None] * closing, 0.0), np.where(on, self.kn[:, None],
                                                                        0.0)

    def evaluate(self, g: np.ndarray, harmonics: Harmonics, *, jacobian: bool = True,
                 histories: bool = False, corrections: bool = True) -> ContactResponse:
        """Force coefficients (P, 1, nc) and their exact derivatives (P, 1, nc, 1, nc):
        ``A diag(f'(u)) E`` (AFT); states: stick (always closed), open, or partial lift-off
        (the unilateral spring's)."""
        E, A = harmonics.synthesis, harmonics.analysis
        P = self.size
        u = np.asarray(g, dtype=float)[:, 0, :] @ E.T  # (P, ns)
        f, df = self.force(u)
        forces = (f @ A.T)[:, None, :]
        J = None
        if jacobian:
            J = np.einsum("ks,ps,sj->pkj", A, df, E)[:, None, :, None, :]
        closed = np.ones_like(u, dtype=bool) if self.law == "polynomial" else f > 0.0
        state = np.where(closed.all(axis=1), STICK,
                         np.where(closed.any(axis=1), PARTIAL_LIFTOFF, OPEN)).astype(np.int8)
        zero = np.zeros(P)
        return ContactResponse(forces, J, np.zeros_like(forces) if jacobian else None, state,
                               zero, zero, zero, np.ones(P, dtype=np.int64),
                               np.zeros(P, dtype=np.int64),
                               T=f[:, None, :] if histories else None,
                               u=u[:, None, :] if histories else None)

    def stuck_stiffness(self) -> np.ndarray:
        """(P, 1) the tangent at rest: c_1, or kn where the gap is closed at rest."""
        if self.law == "polynomial":
            return self.coefficients[:, :1].copy()
        return np.where(self.gap < 0.0, self.kn, 0.0)[:, None]

    def with_preload(self, multiplier: float) -> SpringSet:
        return self

    def preload_derivative(self, response: ContactResponse) -> np.ndarray:
        return np.zeros_like(response.forces)

    def force_scale(self) -> float:
        """The force at a unit-scale displacement (1 mm): a fallback residual scale."""
        u = np.full((self.size, 1), 1e-3)
        return float(max(np.abs(self.force(u)[0]).max(), 1e-300))


@dataclass(frozen=True)
class PolynomialLaw:
    """``law = "polynomial"``: ``coefficients = [c_1, ..., c_n]`` [N/m^p] on motion ``u``."""

    name: str = "polynomial"
    motions: tuple[str, ...] = ("u",)
    parameters: tuple[str, ...] = ()
    reference: str = "Duffing 1918; the nonlinear-dynamics benchmarks (NLvib, tmdsimpy)"

    def check(self, pre: str, table: Mapping[str, Any], out: list[str]) -> None:
        """Append a line per fault of its own keys (``coefficients``)."""
        c = table.get("coefficients")
        if not (isinstance(c, list) and c and all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)
                for x in c)):
            out.append(f"{pre}.coefficients = {c!r}: expected [c_1, c_2, ...] (finite numbers, "
                       "N/m^p: f = sum c_p u^p)")

    @property
    def keys(self) -> tuple[str, ...]:
        return ("coefficients",)

    def elements(self, table: Mapping[str, Any], n_points: int = 1) -> SpringSet:
        c = np.asarray(table["coefficients"], dtype=float)
        return SpringSet("polynomial", coefficients=np.tile(c, (n_points, 1)))


@dataclass(frozen=True)
class UnilateralLaw:
    """``law = "unilateral"``: ``kn`` [N/m] and ``gap`` [m] on motion ``u``."""

    name: str = "unilateral"
    motions: tuple[str, ...] = ("u",)
    parameters: tuple[str, ...] = ("kn", "gap")
    reference: str = "contact without friction: impacts and rubs"

    def check(self, pre: str, table: Mapping[str, Any], out: list[str]) -> None:
        kn = table.get("kn")
        if isinstance(kn, (int, float)) and not isinstance(kn, bool) and not kn > 0:
            out.append(f"{pre}.kn = {kn!r}: expected a stiffness > 0 [N/m]")

    @property
    def keys(self) -> tuple[str, ...]:
        return ()

    def elements(self, table: Mapping[str, Any], n_points: int = 1) -> SpringSet:
        return SpringSet("unilateral", kn=np.full(n_points, float(table["kn"])),
                         gap=np.full(n_points, float(table["gap"])))
