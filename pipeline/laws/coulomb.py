"""Friction contact elements in the frequency domain (Firrone & Zucca section 3 and 4.2).

Four laws (Firrone & Zucca sections 3 and 4.2), each vectorised over many points with per-point
parameters:

====  ============  ===============  =====================================
law   tangential    normal load      reference
====  ============  ===============  =====================================
A     1D            constant N0      Griffin 1980
B     1D            variable         Yang et al. 1998; Petrov & Ewins 2003
C     2D (circle)   constant N0      Sanliturk & Ewins 1996; Menq & Yang 1998
D     2D (circle)   variable         Yang & Menq 1998
====  ============  ===============  =====================================

Inputs per point are the Fourier coefficients of the relative displacements
``u`` (tangential, d components) and ``v`` (normal, positive when the bodies
approach, variable laws only); outputs are the coefficients of the tangential
force ``T`` and of the normal force ``N`` (variable laws), both resisting the
relative motion: on the DOFs they act as ``-B^T [T; N]``.

Forms
-----
uncoupled (Firrone & Zucca eq. 13/17): ``N = max(N0 + kn v, 0)`` with ``N0`` given a
    priori; the static (0th) harmonic of the inputs is ignored and the static
    part of the forces is not returned: the static state was solved before.
coupled (Firrone & Zucca eqs. 24-28): ``N = max(kn (interference + v), 0)`` with ``v``
    holding its 0th harmonic; the tangential static force follows from the 0th
    harmonic of ``u`` (unique under slip, the predictor/corrector of eqs.
    26-28 under full stick). Internally ``n0 = kn * interference``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from microslip.fourier import Harmonics

from . import returnmap
from .states import GROSS_SLIP, OPEN, PARTIAL_LIFTOFF, STATE_NAMES, STICK, STICK_SLIP


@dataclass(frozen=True)
class FrictionLaw:
    """A friction law of the reference text (a :class:`.law.ContactLaw`): ``dim``
    tangential directions, a constant or variable normal load. Its case table gives
    ``kt``, ``mu``, ``form`` and ``n0`` (or, coupled with a variable load,
    ``interference``), and ``kn`` for a variable load."""

    name: str
    dim: int
    variable_normal: bool
    reference: str

    @property
    def motions(self) -> tuple[str, ...]:
        tangential = ("u",) if self.dim == 1 else ("u1", "u2")
        return tangential + (("v",) if self.variable_normal else ())

    @property
    def parameters(self) -> tuple[str, ...]:
        """The parameter keys its table may give (which are required depends on the form
        and the normal load: the case reader's friction rules)."""
        return ("form", "kt", "mu", "n0") + (("kn", "interference") if self.variable_normal
                                              else ())

    def elements(self, table: Mapping[str, Any], n_points: int = 1) -> ContactElements:
        values: dict[str, Any] = dict(kt=np.atleast_1d(np.array(table["kt"], dtype=float))[None, :],
                                      mu=table["mu"],
                                      coupled=table.get("form", FORMS[0]) == "coupled",
                                      kn=table.get("kn", 0.0), n_points=n_points)
        if "interference" in table:
            values["interference"] = table["interference"]
        else:
            values["n0"] = table["n0"]
        return ContactElements.create(self.name, **values)


#: The friction laws' two forms: the static state solved before, N0 a priori (eq. 13/17),
#: or the static and dynamic parts solved together (eqs. 24-28); the first is the default.
FORMS = ("uncoupled", "coupled")


#: The friction laws of the reference text, by the name a case gives (``law = "A"``); every
#: contact law, these and the springs, is in ``registry.LAWS``.
FRICTION_LAWS: dict[str, FrictionLaw] = {law.name: law for law in (
    FrictionLaw("A", 1, False, "Griffin 1980"),
    FrictionLaw("B", 1, True, "Yang et al. 1998; Petrov & Ewins 2003"),
    FrictionLaw("C", 2, False, "Sanliturk & Ewins 1996; Menq & Yang 1998"),
    FrictionLaw("D", 2, True, "Yang & Menq 1998"),
)}



def slip_share(state: np.ndarray) -> float:
    """The share of points (node pairs) that slip over the period: stick-slip or gross slip
    (a point that also lifts off counts as partial lift-off, not as slipping)."""
    return float(np.isin(state, (STICK_SLIP, GROSS_SLIP)).mean()) if np.size(state) else 0.0




def _per_point(name: str, value, shape: tuple[int, ...], *, positive=False, nonneg=False):
    arr = np.asarray(value, dtype=float)
    try:
        arr = np.broadcast_to(arr, shape).astype(float)
    except ValueError:
        raise ValueError(
            f"contact: '{name}' has shape {np.shape(value)}, expected a scalar or {shape}"
        ) from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"contact: '{name}' must be finite, got {value!r}")
    if positive and np.any(arr <= 0):
        raise ValueError(f"contact: '{name}' must be > 0, got min {arr.min():g}")
    if nonneg and np.any(arr < 0):
        raise ValueError(f"contact: '{name}' must be >= 0, got min {arr.min():g}")
    return arr


@dataclass(frozen=True)
class ContactResponse:
    """Result of evaluating a contact set at one state.

    forces: (P, c, nc) coefficients of ``[T_1, ..., T_d, (N)]`` per point, N.
    jacobian: (P, c, nc, c, nc) d forces / d relative displacements, N/m; or None.
    d_n0: (P, c, nc) d forces / d n0 (preload), dimensionless; or None.
    state: (P,) int, one of STICK .. OPEN over the period.
    slip_fraction: (P,) fraction of the samples in slip.
    dissipation: (P,) energy dissipated by friction per cycle, J (``oint T . du``).
    normal_work: (P,) work of the normal force per cycle, J: zero for an
        elastic normal spring up to the time discretisation (a check).
    periods: (P,) periods marched before the cycle repeated.
    undersampled: (P,) stick arcs per period resolved by at most two samples (or
        none: the force reverses between two slipping samples). The sampled
        force then changes in steps as a transition crosses a sample, and Newton
        may stall to a residual of that size; more samples help.
    T, N, u, v: time histories (P, d, ns), (P, ns), (P, d, ns), (P, ns) if asked, sampled
        from the elements' start phase.
    flags: (P, ns) int8 per-sample state (SAMPLE_STICK, SAMPLE_SLIP, SAMPLE_OPEN) if asked.
    """

    forces: np.ndarray
    jacobian: np.ndarray | None
    d_n0: np.ndarray | None
    state: np.ndarray
    slip_fraction: np.ndarray
    dissipation: np.ndarray
    normal_work: np.ndarray
    periods: np.ndarray
    undersampled: np.ndarray
    T: np.ndarray | None = None
    N: np.ndarray | None = None
    u: np.ndarray | None = None
    v: np.ndarray | None = None
    flags: np.ndarray | None = None

    @property
    def state_names(self) -> list[str]:
        return [STATE_NAMES[s] for s in self.state]


@dataclass(frozen=True, eq=False)
class ContactElements:
    """P friction contact points sharing one law and form.

    Parameters (per point, broadcast from scalars)
    ----------
    law: "A", "B", "C" or "D".
    kt: tangential contact stiffness, N/m, shape (P,) or (P, d) (k_tx, k_ty).
    mu: friction coefficient, >= 0.
    n0: normal preload N0, N (uncoupled; negative means an initial gap for the
        variable laws), or ``kn * interference`` (coupled).
    kn: normal contact stiffness, N/m (> 0 for the variable laws B and D; 0 for
        A and C).
    coupled: static/dynamic coupling (Firrone & Zucca section 4.2).
    start_phase: where in the period, rad of the fundamental, the march starts from its
        convention (a contact sticking all period after slipping in its first periods keeps
        the offset that start gave it). 0 is the time origin of the harmonics. The whole
        disk gives sector s's contacts its own excitation's start, so every sector's
        contacts meet the same point of their cycle (a tuned disk is then the travelling
        wave to rounding).
    """

    law: str
    kt: np.ndarray
    kn: np.ndarray
    mu: np.ndarray
    n0: np.ndarray
    coupled: bool = False
    start_phase: float = 0.0

    @classmethod
    def create(
        cls,
        law: str,
        *,
        kt,
        mu,
        n0=None,
        kn=0.0,
        interference=None,
        coupled: bool = False,
        n_points: int | None = None,
        start_phase: float = 0.0,
    ) -> ContactElements:
        """Validate and broadcast per-point parameters.

        Give ``n0`` (N) for the uncoupled form, ``interference`` (m, negative
        for a gap) for the coupled form of the variable laws, or ``n0`` for the
        coupled form of the constant-load laws A and C."""
        if law not in FRICTION_LAWS:
            raise ValueError(f"contact: 'law' = {law!r} is not one of {sorted(FRICTION_LAWS)}")
        d, variable = FRICTION_LAWS[law].dim, FRICTION_LAWS[law].variable_normal
        if n_points is None:
            sizes = [np.size(x) for x in (mu, n0, kn, interference) if x is not None]
            sizes.append(np.size(kt) // d if np.ndim(kt) == 2 else np.size(kt))
            n_points = max(sizes)
        P = int(n_points)
        if P < 1:
            raise ValueError(f"contact: 'n_points' must be >= 1, got {n_points}")
        kt_arr = np.asarray(kt, dtype=float)
        if kt_arr.ndim <= 1:
            kt_arr = np.broadcast_to(kt_arr.reshape(-1, 1) if kt_arr.ndim else kt_arr, (P, d))
        kt_arr = _per_point("kt", kt_arr, (P, d), positive=True)
        mu_arr = _per_point("mu", mu, (P,), nonneg=True)
        kn_arr = _per_point("kn", kn, (P,), nonneg=True)
        if variable and np.any(kn_arr <= 0):
            raise ValueError(f"contact: law {law} needs 'kn' > 0, got min {kn_arr.min():g}")
        if not variable and np.any(kn_arr != 0):
            raise ValueError(f"contact: law {law} has a constant normal load; 'kn' must be 0")
        if interference is not None:
            if not (coupled and variable):
                raise ValueError(
                    "contact: 'interference' applies to the coupled form of laws B and D; "
                    f"got law {law}, coupled={coupled}"
                )
            if n0 is not None:
                raise ValueError("contact: give either 'n0' or 'interference', not both")
            n0_arr = kn_arr * _per_point("interference", interference, (P,))
        else:
            if n0 is None:
                raise ValueError(f"contact: law {law} needs 'n0' (N) or, coupled, 'interference'")
            n0_arr = _per_point("n0", n0, (P,))
            if not variable and np.any(n0_arr < 0):
                raise ValueError(
                    f"contact: law {law} has a constant normal load; 'n0' must be >= 0, "
                    f"got min {n0_arr.min():g}"
                )
        if not np.isfinite(start_phase):
            raise ValueError(f"contact: 'start_phase' must be finite, got {start_phase}")
        return cls(law, kt_arr, kn_arr, mu_arr, n0_arr, bool(coupled), float(start_phase))

    # ----------------------------------------------------------------- layout
    @property
    def dim(self) -> int:
        """Tangential dimension d."""
        return FRICTION_LAWS[self.law].dim

    @property
    def variable_normal(self) -> bool:
        return FRICTION_LAWS[self.law].variable_normal

    @property
    def n_components(self) -> int:
        """Relative-displacement components per point: d (+1 normal)."""
        return self.dim + int(self.variable_normal)

    @property
    def size(self) -> int:
        return self.kt.shape[0]

    def with_n0(self, n0) -> ContactElements:
        """Same contacts with another preload (continuation in N0)."""
        return replace(self, n0=_per_point("n0", n0, (self.size,)))

    # ----------------------------------------------------- the law interface
    def stuck_stiffness(self) -> np.ndarray:
        """(P, n_components) N/m: kt per tangential direction, kn normal."""
        k = np.zeros((self.size, self.n_components))
        k[:, : self.dim] = self.kt
        if self.variable_normal:
            k[:, -1] = self.kn
        return k

    def with_preload(self, multiplier: float) -> ContactElements:
        """The preload parameter scales n0 (N0, or kn x interference)."""
        return self if multiplier == 1 else self.with_n0(self.n0 * multiplier)

    def preload_derivative(self, response: ContactResponse) -> np.ndarray:
        """d forces / d preload multiplier = d forces / d n0 x n0 (these points' n0)."""
        return response.d_n0 * self.n0[:, None, None]

    def force_scale(self) -> float:
        """The largest friction limit mu N0 (N0 where mu < 1)."""
        return float(np.max(np.abs(self.n0) * np.maximum(self.mu, 1.0)))

    # ------------------------------------------------------------- evaluation
    def evaluate(
        self,
        g: np.ndarray,
        harmonics: Harmonics,
        *,
        jacobian: bool = True,
        histories: bool = False,
        max_periods: int = 200,
        rtol: float = 1e-13,
        corrections: bool = True,
    ) -> ContactResponse:
        """Forces (and their derivatives) for relative displacements ``g``.

        g: (P, c, nc) Fourier coefficients of ``[u_1, ..., u_d, (v)]``, m, in the
        layout of ``harmonics``. ``rtol`` ends the march when the force at the
        end of a period repeats to ``rtol`` times the force scale.
        """
        P, c, nc = self.size, self.n_components, harmonics.n_coeffs
        g = np.asarray(g, dtype=float)
        if g.shape != (P, c, nc):
            raise ValueError(
                f"contact: relative displacements have shape {g.shape}, expected (P, c, nc) = "
                f"{(P, c, nc)} for law {self.law} with {P} points and {nc} coefficients"
            )
        if not np.all(np.isfinite(g)):
            raise ValueError("contact: relative displacements contain NaN or Inf")
        if self.start_phase:  # march from the start: evaluate x(theta + start), turn back
            Q = harmonics.time_shift(self.start_phase)
            r = replace(self, start_phase=0.0).evaluate(
                g @ Q.T, harmonics, jacobian=jacobian, histories=histories,
                max_periods=max_periods, rtol=rtol, corrections=corrections)
            jac = r.jacobian
            if jac is not None:
                jac = np.einsum("ji,pajbk,kl->paibl", Q, jac, Q, optimize=True)
            return replace(r, forces=r.forces @ Q, jacobian=jac,
                           d_n0=None if r.d_n0 is None else r.d_n0 @ Q)
        static = harmonics.static_mask
        if not self.coupled and static.any():
            g = g.copy()
            g[..., static] = 0.0
        d, ns = self.dim, harmonics.n_samples
        E, A = harmonics.synthesis, harmonics.analysis
        u = np.empty((P, d, ns))
        v = np.empty((P, ns))
        T = np.empty((P, d, ns))
        N = np.empty((P, ns))
        st = np.empty((P, ns), dtype=np.int8)
        F = np.empty((P, d + 1, nc))
        jac = np.empty((P, c, nc, c, nc) if jacobian else (1, 1, 1, 1, 1))
        dn0 = np.empty((P, c, nc) if jacobian else (1, 1, 1))
        periods = np.empty(P, dtype=np.int64)
        counts = np.empty((P, 3), dtype=np.int64)
        returnmap.march(
            np.ascontiguousarray(g), u, v, self.kt, self.kn, self.mu, self.n0, E, A,
            harmonics.coeff_order.astype(float), harmonics.coeff_kind, self.variable_normal,
            jacobian, int(max_periods), float(rtol), bool(corrections), T, N, st, F,
            jac.reshape(jac.shape[0], c, nc, -1) if jacobian else jac.reshape(1, 1, 1, 1),
            dn0, periods, counts,
        )
        forces = F[:, :c]
        if not jacobian:
            jac = dn0 = None
        if not self.coupled and static.any():
            forces[..., static] = 0.0
            if jacobian:
                jac[:, :, static] = 0.0
                jac[..., static] = 0.0
                dn0[..., static] = 0.0
        state, slip_fraction = _classify(counts, ns)
        dissipation = harmonics.work(forces[:, :d], g[:, :d]).sum(axis=1)
        normal_work = (
            harmonics.work(forces[:, d], g[:, d]) if self.variable_normal else np.zeros(P)
        )
        extra = {}
        if histories:
            extra = {"T": T, "N": N, "u": u, "v": v, "flags": st}
        return ContactResponse(
            forces, jac, dn0, state, slip_fraction, dissipation, normal_work, periods,
            counts[:, 2], **extra
        )


def _classify(counts: np.ndarray, ns: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-point state over the period from (open, slipping) sample counts."""
    n_open, n_slip = counts[:, 0], counts[:, 1]
    state = np.full(counts.shape[0], STICK)
    state[n_slip > 0] = STICK_SLIP
    state[(n_slip > 0) & (n_slip + n_open == ns)] = GROSS_SLIP
    state[n_open > 0] = PARTIAL_LIFTOFF
    state[n_open == ns] = OPEN
    return state, n_slip / ns
