"""Multi-harmonic balance on the contact DOFs (Firrone & Zucca section 2 and appendix).

For each kept harmonic order n the linear part is the dynamic stiffness
``D_n(w) = K_n - (n w)^2 M_n + i n w C_n`` (real, or complex Hermitian from the
cyclic-symmetry stage). DOFs that no contact touches are condensed exactly per
harmonic, ``S_n = D_cc - D_ci D_ii^-1 D_ic``, so the unknowns are the contact
DOFs only and no receptance (``K^-1`` at n = 0) is needed: a free-free damper
held only by its contacts is fine. Every other DOF is recovered afterwards
(Firrone & Zucca eq. 9).

Unknowns ``x`` are real, DOF-major: ``x[dof, coeff]`` in the layout of
:class:`~microslip.fourier.Harmonics`. The residual is

    R(x) = S x - F + B^T f(B x)

with ``f`` the contact forces (resisting the relative displacements ``B x``).
Scalar parameters that continuation may follow (``PARAMETERS``):

frequency   w, rad/s
excitation  multiplier of the dynamic (n >= 1) external forces; static loads stay
mass        multiplier s of ``LinearDynamics.mass_part``: ``M(s) = M + (s - 1) M_part``
preload     multiplier of every contact's ``n0`` (``N0`` or ``kn * interference``)
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from microslip.fourier import Harmonics
from microslip.laws.coulomb import ContactResponse
from microslip.laws.interface import ContactSet
from microslip.solve.condensation import (
    Condensed,
    Reordered,
    condense,
    condensed_dofs,
    solve_orders,
)
from microslip.solve.jacobian import BalanceJacobian, PointBlocks, Preconditioner

PARAMETERS = ("frequency", "excitation", "mass", "preload")
_DENSE_LIMIT = 400_000  # entries of the real kinematic map kept dense
#: Unknowns from which continuation uses the structured Jacobian (see ``structured``).
STRUCTURED_FROM = 600


def structured_by_default(n_dof: int, n_coeffs: int) -> bool:
    """Whether "auto" solves with the structured Jacobian: from STRUCTURED_FROM unknowns,
    where the contact DOFs are at least as many as the coefficients. Its preconditioner is
    the order-diagonal part; with few DOFs and many orders (one DOF at H = 300) nearly all
    of the Jacobian is the coupling of the orders it leaves out (GMRES then takes its
    full 80 iterations and more), and the dense LU of that size is cheap anyway."""
    return n_dof * n_coeffs >= STRUCTURED_FROM and n_dof >= n_coeffs
#: How Newton solves with the Jacobian: "dense" (LU), "structured" (solve.jacobian) or
#: "auto" (structured from STRUCTURED_FROM unknowns).
JACOBIANS = ("auto", "dense", "structured")


@dataclass(frozen=True)
class OperatingPoint:
    """Values of the scalar parameters at which the balance is solved.

    omega: angular frequency [rad/s]; excitation, mass_multiplier, preload: dimensionless
    multipliers (see ``PARAMETERS``; a continuation parameter name maps to its field).
    """

    omega: float
    excitation: float = 1.0
    mass_multiplier: float = 1.0
    preload: float = 1.0

    def get(self, name: str) -> float:
        return getattr(self, _field(name))

    def set(self, name: str, value: float) -> OperatingPoint:
        return replace(self, **{_field(name): float(value)})


_FIELDS = {"frequency": "omega", "excitation": "excitation", "mass": "mass_multiplier",
           "preload": "preload"}  # continuation parameter -> OperatingPoint field


def _field(name: str) -> str:
    if name not in PARAMETERS:
        raise ValueError(f"hbm: parameter {name!r} is not one of {PARAMETERS}")
    return _FIELDS[name]


def _combined(M: np.ndarray, m: float, K: np.ndarray | None, C: np.ndarray | None,
              c: float) -> np.ndarray:
    """m M + K + i c C as a new array (real where all are real and C is None), in place
    after the first product (a Newton iterate forms every order's at a new frequency: half
    the memory traffic of the expression's temporaries)."""
    D = np.multiply(M, m, dtype=np.result_type(M, K if K is not None else M,
                                               float if C is None else complex))
    if K is not None:
        D += K
    if C is not None:
        if np.iscomplexobj(C):
            D.real -= c * C.imag
        D.imag += c * C.real
    return D


def _per_order(name: str, value, orders: tuple[int, ...],
               sizes: tuple[int, ...] | None) -> tuple[np.ndarray, ...]:
    """Per-order square complex matrices; a single matrix serves every order."""
    if isinstance(value, Mapping):
        missing = [o for o in orders if o not in value]
        if missing:
            raise ValueError(f"hbm: '{name}' has no matrix for harmonic orders {missing}")
        raw = [value[o] for o in orders]
    else:
        raw = [value] * len(orders)
    mats = []
    for k, (o, m) in enumerate(zip(orders, raw)):
        m = np.asarray(m, dtype=complex)
        if m.ndim != 2 or m.shape[0] != m.shape[1]:
            raise ValueError(f"hbm: '{name}' must be square matrices, got shape {m.shape} "
                             f"(order {o})")
        if sizes is not None and m.shape[0] != sizes[k]:
            raise ValueError(f"hbm: '{name}' is {m.shape[0]}x{m.shape[0]}, expected "
                             f"{sizes[k]}x{sizes[k]} (order {o})")
        if not np.all(np.isfinite(m)):
            raise ValueError(f"hbm: '{name}' contains NaN or Inf")
        mats.append(m)
    return tuple(mats)


@dataclass(frozen=True, eq=False)
class LinearDynamics:
    """The linear part per harmonic order: K_n, M_n, C_n.

    Each argument is one matrix for every order (lumped models) or a mapping
    ``{order: matrix}`` (cyclic symmetry: the matrices of the order's nodal
    diameter). ``mass_part`` is the part of M a mass multiplier scales.

    The matrices of order n are (n_n, n_n) with n_n >= ``n_dof``: the first ``n_dof``
    DOFs are shared by every order (the physical DOFs the contacts, loads and outputs
    use: the master DOFs of reduced bodies); those past ``n_dof`` belong to that order
    alone (the fixed-interface modal coordinates of a body at the order's nodal
    diameter, whose number differs between nodal diameters). The harmonic balance
    condenses them per order, so nothing forces equal sizes. Lumped models: n_n = n_dof.
    """

    K: tuple[np.ndarray, ...]  # per order, (n_n, n_n) complex
    M: tuple[np.ndarray, ...]
    C: tuple[np.ndarray, ...]
    M_part: tuple[np.ndarray, ...]
    orders: tuple[int, ...]
    n_dof: int
    #: the masses at the last mass multiplier asked (:meth:`mass`)
    _scaled: dict = field(default_factory=dict, init=False, repr=False)

    @classmethod
    def create(cls, K, M, C=None, *, harmonics: Harmonics, mass_part=None,
               n_shared: int | None = None) -> LinearDynamics:
        """n_shared: DOFs common to every order (default: the smallest order's size)."""
        orders = harmonics.orders
        Ks = _per_order("K", K, orders, None)
        sizes = tuple(k.shape[0] for k in Ks)
        Ms = _per_order("M", M, orders, sizes)
        zeros = {o: np.zeros((n, n)) for o, n in zip(orders, sizes)}
        Cs = _per_order("C", zeros if C is None else C, orders, sizes)
        Mp = _per_order("mass_part", zeros if mass_part is None else mass_part, orders, sizes)
        n = min(sizes) if n_shared is None else int(n_shared)
        if not 0 <= n <= min(sizes):
            raise ValueError(f"hbm: n_shared = {n_shared} must be in 0..{min(sizes)} (the "
                             "smallest order's size)")
        for name, mats in (("K", Ks), ("M", Ms), ("C", Cs)):
            for o, A in zip(orders, mats):
                asym = np.abs(A - A.conj().T).max(initial=0.0)
                if asym > 1e-9 * max(np.abs(A).max(initial=0.0), 1e-300):
                    raise ValueError(f"hbm: '{name}' is not symmetric (Hermitian): max "
                                     f"|A - A^H| = {asym:.3g} (order {o})")
        if 0 in orders:
            K0 = Ks[orders.index(0)]
            if np.abs(K0.imag).max(initial=0.0) > 1e-12 * max(np.abs(K0).max(initial=0.0),
                                                               1e-300):
                raise ValueError("hbm: 'K' of harmonic order 0 must be real (nodal diameter 0)")
        return cls(Ks, Ms, Cs, Mp, orders, n)

    @property
    def sizes(self) -> tuple[int, ...]:
        """(n_n,) per order: shared DOFs plus the order's own."""
        return tuple(k.shape[0] for k in self.K)

    def mass(self, point: OperatingPoint) -> tuple[np.ndarray, ...]:
        """Per order M(s) = M + (s - 1) M_part at the point's mass multiplier s.

        The one mechanism of mass studies (a damper's mass as a multiple of its nominal
        mass): exact for a reduced body, whose basis does not depend on its density.
        """
        s = point.mass_multiplier
        if s == 1.0:
            return self.M
        if s not in self._scaled:  # a sweep at one mass forms it once, not per iterate
            self._scaled.clear()
            self._scaled[s] = tuple(M + (s - 1.0) * Mp if scaled else M
                                    for M, Mp, scaled in zip(self.M, self.M_part,
                                                             self._nonzero[1]))
        return self._scaled[s]

    @cached_property
    def _nonzero(self) -> tuple[tuple[bool, ...], tuple[bool, ...]]:
        """Per order whether C and M_part have any nonzero entry: zero ones are skipped
        (an undamped body, a cyclic body no mass multiplier scales)."""
        return (tuple(bool(np.any(C)) for C in self.C),
                tuple(bool(np.any(Mp)) for Mp in self.M_part))

    def dynamic_stiffness(self, point: OperatingPoint) -> tuple[np.ndarray, ...]:
        """Per order D_n = K_n - (n w)^2 M_n + i n w C_n at the point; order 0 is K_0 itself
        (real if stored real: read it, do not write it)."""
        w, damped = point.omega, self._nonzero[0]
        return tuple(K if o == 0 else _combined(M, -((o * w) ** 2), K, C if d else None, o * w)
                     for o, K, M, C, d in zip(self.orders, self.K, self.mass(point), self.C,
                                              damped))

    def d_dynamic_stiffness(self, point: OperatingPoint, parameter: str
                            ) -> tuple[np.ndarray | None, ...] | None:
        """Per order dD_n / d parameter (None at order 0, where D does not depend on w or
        the mass), or None where no order's D depends on it."""
        w, damped = point.omega, self._nonzero[0]
        if parameter == "frequency":
            return tuple(None if o == 0 else _combined(M, -2.0 * o**2 * w, None,
                                                       C if d else None, o)
                         for o, M, C, d in zip(self.orders, self.mass(point), self.C, damped))
        if parameter == "mass":
            return tuple(None if o == 0 else -((o * w) ** 2) * Mp
                         for o, Mp in zip(self.orders, self.M_part))
        return None


@dataclass(frozen=True, eq=False)
class Contact:
    """A named set of contact points of any law (:class:`laws.interface.ContactSet`) and
    their kinematics.

    kinematics: (P * c, n_dof) real matrix, rows ordered (point, component: the law's
    motions, ``[u_1, ..., u_d, (v)]`` for friction), giving the relative displacements from the DOFs
    for every harmonic; or ``{order: complex matrix}`` when it differs per
    order (a contact with the neighbouring sector: phase ``exp(i n EO phi)``).
    """

    name: str
    elements: ContactSet
    kinematics: np.ndarray | Mapping[int, np.ndarray]


@dataclass(frozen=True, eq=False)
class Excitation:
    """External forces ``F(t) = Re(sum_n F_n exp(i n w t))``: {order: complex vector}.

    A vector of ``n_dof`` entries loads the shared DOFs; one of the order's full size n_n
    (see :class:`LinearDynamics`) also loads the order's own DOFs (the load of a reduced body
    has modal components). The excitation multiplier scales the dynamic orders only.

    rotating: a static load per unit squared rotation speed, N/(rad/s)^2, (n_dof,) or the
        order-0 size (the centrifugal load of the bodies); order 0 gets ``speed^2 rotating``
        with ``speed`` [rad/s] fixed, or tied to the excitation frequency through the engine
        order, ``speed = w / engine_order`` (an engine-order excitation sweeps the speed).
    rotating_part: the part of ``rotating`` that the mass multiplier s scales with the mass
        (the centrifugal load of the bodies in ``LinearDynamics.mass_part``): the load at s is
        ``rotating + (s - 1) rotating_part``, as M(s) = M + (s - 1) M_part.
    """

    forces: Mapping[int, np.ndarray]
    rotating: np.ndarray | None = None
    speed: float | None = None
    engine_order: int | None = None
    rotating_part: np.ndarray | None = None

    def __post_init__(self):
        if self.rotating is not None and (self.speed is None) == (self.engine_order is None):
            raise ValueError("hbm: a rotating load needs either 'speed' (rad/s) or "
                             "'engine_order' (speed = w / EO), exactly one")
        if self.engine_order is not None and not self.engine_order > 0:
            raise ValueError(f"hbm: engine_order = {self.engine_order} must be > 0")

    @classmethod
    def single(cls, n_dof: int, dof: int, amplitude: float, order: int = 1,
               phase: float = 0.0) -> Excitation:
        """``amplitude cos(order w t + phase)`` on one DOF."""
        f = np.zeros(n_dof, dtype=complex)
        f[dof] = amplitude * np.exp(1j * phase)
        return cls({order: f})

    def speed_squared(self, omega: float) -> tuple[float, float]:
        """(speed^2, d speed^2 / d w) at excitation frequency ``omega``."""
        if self.rotating is None:
            return 0.0, 0.0
        if self.speed is not None:
            return float(self.speed) ** 2, 0.0
        eo = float(self.engine_order)
        return (omega / eo) ** 2, 2.0 * omega / eo**2

    def vectors(self, orders: tuple[int, ...], sizes: tuple[int, ...], n_dof: int
                ) -> tuple[tuple[np.ndarray, ...], np.ndarray | None, np.ndarray | None]:
        """(per order (n_n,) complex forces of the kept orders, the (n_0,) rotating load of
        order 0 and its mass-scaled part, or None)."""
        out = []
        for o, n in zip(orders, sizes):
            F = np.zeros(n, dtype=complex)
            if o in self.forces:
                f = np.asarray(self.forces[o], dtype=complex)
                if f.shape not in ((n_dof,), (n,)):
                    raise ValueError(f"hbm: excitation of order {o} has shape {f.shape}, "
                                     f"expected ({n_dof},) or ({n},)")
                F[: f.size] = f
            out.append(F)
        if self.rotating is None:
            return tuple(out), None, None
        if 0 not in orders:
            raise ValueError("hbm: a rotating (static) load needs harmonic order 0")
        n0 = sizes[orders.index(0)]
        rot = []
        for name, value in (("rotating", self.rotating), ("rotating_part", self.rotating_part)):
            f = np.zeros(n0) if value is None else np.asarray(value, dtype=float)
            if f.shape not in ((n_dof,), (n0,)):
                raise ValueError(f"hbm: {name} load has shape {f.shape}, expected ({n_dof},) "
                                 f"or ({n0},)")
            vec = np.zeros(n0, dtype=complex)
            vec[: f.size] = f
            rot.append(vec)
        return tuple(out), rot[0], rot[1]


class HarmonicBalance:
    """The nonlinear algebraic system of one model at given harmonics.

    Build once; evaluate :meth:`residual` for any state and operating point.
    """

    def __init__(
        self,
        linear: LinearDynamics,
        contacts: Sequence[Contact],
        excitation: Excitation,
        harmonics: Harmonics,
        *,
        sub_sample: bool = True,
        jacobian: str = "auto",
    ):
        if tuple(linear.orders) != harmonics.orders:
            raise ValueError(
                f"hbm: linear part built for orders {linear.orders}, harmonics are "
                f"{harmonics.orders}"
            )
        self.linear = linear
        self.harmonics = harmonics
        self.sub_sample = bool(sub_sample)
        if jacobian not in JACOBIANS:
            raise ValueError(f"hbm: jacobian = {jacobian!r} is not one of {JACOBIANS}")
        self.jacobian = jacobian
        self.excitation = excitation
        self.contacts = tuple(contacts)
        n = linear.n_dof
        self._forces, self._rotating, self._rotating_part = excitation.vectors(
            harmonics.orders, linear.sizes, n)
        names = [c.name for c in self.contacts]
        if len(set(names)) != len(names):
            raise ValueError(f"hbm: contact names must be unique, got {names}")
        used = np.zeros(n, dtype=bool)
        self._B = []
        for c in self.contacts:
            B = self._kinematics(c)
            for mat in B.values():
                used |= np.any(mat != 0, axis=0)
            self._B.append(B)
        self.dofs = np.flatnonzero(used)  # the unknowns: contact DOFs
        self.others = np.flatnonzero(~used)  # shared DOFs no contact touches
        self._Breal = [self._real_kinematics(B) for B in self._B]
        self._blocks = [PointBlocks.of(Br, c.elements.size, harmonics.n_coeffs)
                        for c, Br in zip(self.contacts, self._Breal)]
        self._cache = _Cache()
        self.preconditioner = Preconditioner()  # the structured Newton's, shared by copies
        self._by_samples: dict[int, HarmonicBalance] = {}  # shared by every resampled copy

    def with_samples(self, n_samples: int) -> HarmonicBalance:
        """The same model with the period sampled at ``n_samples`` instants: the linear part,
        kinematics and their cache (none depends on the sampling) shared; made once per
        sample count (a check at many points asks for the same one)."""
        if n_samples == self.harmonics.n_samples:
            return self
        if n_samples not in self._by_samples:
            out = copy.copy(self)
            out.harmonics = Harmonics(self.harmonics.orders, n_samples)
            self._by_samples[n_samples] = out
        return self._by_samples[n_samples]

    @cached_property
    def lumped(self) -> bool:
        """Whether the linear part is the same at every order (a lumped model; a cyclic
        one's differs by nodal diameter)."""
        K = self.linear.K
        return all(k.shape == K[0].shape and np.array_equal(k, K[0]) for k in K)

    def consecutive(self) -> HarmonicBalance:
        """The same model on every order from 0 to the highest kept (the Hill problem of
        stability needs them: a perturbation is not restricted to the solution's
        harmonics, e.g. the even ones of a period doubling beside odd ones). Only for
        models whose linear part is the same at every order (lumped ones); ValueError
        otherwise. Made once."""
        h = self.harmonics
        if h.orders == tuple(range(h.orders[0], h.orders[-1] + 1)) and h.orders[0] <= 1:
            return self
        key = ("consecutive",)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        lin = self.linear
        if not self.lumped:
            raise ValueError(f"hbm: harmonic orders {list(h.orders)} are not consecutive "
                             "and the linear part differs per order (cyclic symmetry): no "
                             "stability (keep every order from 0 or 1 to the highest)")
        full = Harmonics(range(h.orders[-1] + 1), h.n_samples)
        out = HarmonicBalance(
            LinearDynamics.create(lin.K[0], lin.M[0], lin.C[0], harmonics=full,
                                  mass_part=lin.M_part[0]),
            self.contacts, self.excitation, full, sub_sample=self.sub_sample,
            jacobian=self.jacobian)
        self._cache.put(key, out, 0, pinned=True)
        return out

    def embed(self, x: np.ndarray, other: HarmonicBalance) -> np.ndarray:
        """The unknowns ``x`` of this model in the layout of ``other`` (the same contact
        DOFs, other orders: those missing here are zero)."""
        h = self.harmonics
        X = h.to_complex(x.reshape(self.dofs.size, h.n_coeffs))
        return other.harmonics.from_complex(X, (self.dofs.size,)).ravel()

    @property
    def F_ext(self) -> np.ndarray:
        """(n_orders, n_dof) complex external forces on the shared DOFs at unit multipliers
        (the rotating load not included)."""
        return np.array([f[: self.linear.n_dof] for f in self._forces])

    def forces(self, point: OperatingPoint, parameter: str | None = None
               ) -> tuple[list[np.ndarray], list[np.ndarray] | None]:
        """Per order the (n_n,) external forces at the point and, with ``parameter``, their
        derivatives: the excitation multiplier scales the dynamic orders, the rotating load
        enters order 0 as speed^2 times it (its mass part times the mass multiplier)."""
        s2, ds2 = self.excitation.speed_squared(point.omega)
        F, dF = [], []
        for o, f in zip(self.harmonics.orders, self._forces):
            g = f * point.excitation if o > 0 else f.copy()
            d = f if (o > 0 and parameter == "excitation") else np.zeros_like(f)
            if o == 0 and self._rotating is not None:
                rot = self._rotating + (point.mass_multiplier - 1.0) * self._rotating_part
                g += s2 * rot
                if parameter == "frequency":
                    d = d + ds2 * rot
                elif parameter == "mass":
                    d = d + s2 * self._rotating_part
            F.append(g)
            dF.append(d)
        return F, (dF if parameter is not None else None)

    # --------------------------------------------------------------- set-up
    def _kinematics(self, c: Contact) -> dict[int, np.ndarray]:
        rows = c.elements.size * c.elements.n_components
        n = self.linear.n_dof
        if isinstance(c.kinematics, Mapping):
            missing = [o for o in self.harmonics.orders if o not in c.kinematics]
            if missing:
                raise ValueError(
                    f"hbm: contact '{c.name}' kinematics lacks harmonic orders {missing}"
                )
            B = {o: np.asarray(c.kinematics[o], dtype=complex) for o in self.harmonics.orders}
        else:
            mat = np.asarray(c.kinematics, dtype=float)
            B = {o: mat for o in self.harmonics.orders}
        for o, mat in B.items():
            if mat.shape != (rows, n):
                raise ValueError(
                    f"hbm: contact '{c.name}' kinematics (order {o}) has shape {mat.shape}, "
                    f"expected (points * components, n_dof) = ({rows}, {n})"
                )
            if not np.all(np.isfinite(mat)):
                raise ValueError(f"hbm: contact '{c.name}' kinematics contains NaN or Inf")
        return B

    def _real_kinematics(self, B: dict[int, np.ndarray]) -> np.ndarray | sp.csr_matrix:
        """Real map x (DOF-major, contact DOFs only) -> g (row-major, coeffs).

        Dense while small (sparse bookkeeping costs more than it saves on the
        lumped models), CSR otherwise."""
        h = self.harmonics
        nc = h.n_coeffs
        blocks = []
        for o, mat in B.items():
            Bc = mat[:, self.dofs]
            Br, Bi = np.real(Bc), np.imag(Bc)
            if o == 0:
                sel = np.zeros((nc, nc))
                sel[0, 0] = 1.0
                blocks.append(sp.kron(Br, sel))
                continue
            k = h.dynamic_orders.index(o)
            ia, ib = h.cos_index[k], h.sin_index[k]
            same = np.zeros((nc, nc))
            same[ia, ia] = same[ib, ib] = 1.0
            cross = np.zeros((nc, nc))
            cross[ia, ib] = 1.0
            cross[ib, ia] = -1.0
            blocks.append(sp.kron(Br, same))
            if np.any(Bi != 0):
                blocks.append(sp.kron(Bi, cross))
        Br = sp.csr_matrix(sum(blocks[1:], blocks[0]))
        return Br.toarray() if Br.shape[0] * Br.shape[1] <= _DENSE_LIMIT else Br

    @property
    def n_unknowns(self) -> int:
        return self.dofs.size * self.harmonics.n_coeffs

    # ---------------------------------------------------------- linear part
    def condensed(self, point: OperatingPoint, parameter: str | None = None) -> Condensed:
        """Exact condensation on the contact DOFs (cached per point)."""
        key = (point, parameter)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        lin = self._reordered()
        F, dF = self.forces(point, parameter)
        dD = lin.linear.d_dynamic_stiffness(point, parameter) if parameter else None
        out = condense(lin.linear.dynamic_stiffness(point), lin.take(F), self.dofs.size, dD,
                        None if dF is None else lin.take(dF))
        self._cache.put(key, out, out.nbytes)
        return out

    def _reordered(self) -> Reordered:
        """The linear part reordered for the condensation, built once (pinned in the cache:
        it counts against CACHE_LIMIT but every point needs it)."""
        key = ("reordered",)
        hit = self._cache.get(key)
        if hit is None:
            hit = Reordered.of(self.linear, self.dofs, self.others)
            self._cache.put(key, hit, hit.nbytes, pinned=True)
        return hit

    # ------------------------------------------------------------- residual
    def residual(
        self,
        x: np.ndarray,
        point: OperatingPoint,
        parameter: str | None = None,
        jacobian: bool = True,
        structured: bool = False,
    ) -> tuple[np.ndarray, np.ndarray | BalanceJacobian | None, np.ndarray | None]:
        """R(x), dR/dx and dR/d(parameter) at ``point``.

        x: (n_unknowns,) real, DOF-major over :attr:`dofs`. Returns R (n,),
        J (n, n) or None, dR (n,) or None (if ``parameter`` is None). ``structured``: J
        as a :class:`~microslip.solve.jacobian.BalanceJacobian` (its per-order and
        per-point parts kept apart, solved by preconditioned GMRES) instead of a dense
        matrix.
        """
        lin = self.condensed(point, parameter)
        h = self.harmonics
        # the linear terms per order on the complex blocks; the real operator only for a
        # dense J (a continuation meets every point once: converting S costs what copying a
        # cached real one would, and dS is never needed as a matrix)
        Xd = h.to_complex(x.reshape(self.dofs.size, h.n_coeffs))
        X = np.array([Xd[o] for o in h.orders])
        R = h.real_vector(lin.S_product(X) - lin.F).ravel()
        dense = jacobian and not structured
        J = h.real_matrix(lin.S) if dense else None
        sandwiches = []
        dR = None
        if parameter is not None:
            dR = h.real_vector(lin.dS_product(X) - lin.dF).ravel()
        for c, Br, blocks in zip(self.contacts, self._Breal, self._blocks):
            el = c.elements.with_preload(point.preload)
            g = (Br @ x).reshape(el.size, el.n_components, -1)
            r = el.evaluate(g, self.harmonics, jacobian=jacobian or parameter == "preload",
                            corrections=self.sub_sample)
            R += Br.T @ r.forces.ravel()
            if dense:
                blocks.add_sandwich(J, r.jacobian)
            elif jacobian:
                sandwiches.append((blocks, blocks.sandwich(r.jacobian)))
            if parameter == "preload":
                dR += Br.T @ c.elements.preload_derivative(r).ravel()
        if jacobian and structured:
            J = BalanceJacobian(h, lin, tuple(sandwiches), self.preconditioner)
        return R, J, dR

    @property
    def structured(self) -> bool:
        """Whether continuation solves with the structured Jacobian: as ``jacobian`` says,
        and for "auto" :func:`structured_by_default` (below STRUCTURED_FROM unknowns a dense
        LU costs less than the Krylov iterations)."""
        if self.jacobian == "auto":
            return structured_by_default(self.dofs.size, self.harmonics.n_coeffs)
        return self.jacobian == "structured"

    # ------------------------------------------------------- post-processing
    def relative_displacements(self, x: np.ndarray) -> list[np.ndarray]:
        """Per contact: (P, c, ncoeff) relative displacement coefficients."""
        return [
            (Br @ x).reshape(c.elements.size, c.elements.n_components, -1)
            for c, Br in zip(self.contacts, self._Breal)
        ]

    def contact_response(
        self, x: np.ndarray, point: OperatingPoint, histories: bool = False
    ) -> list[ContactResponse]:
        """Per contact: forces, states, dissipation (and time histories)."""
        out = []
        for c, g in zip(self.contacts, self.relative_displacements(x)):
            el = c.elements.with_preload(point.preload)
            out.append(el.evaluate(g, self.harmonics, jacobian=False, histories=histories,
                                   corrections=self.sub_sample))
        return out

    def recover_orders(self, x: np.ndarray, point: OperatingPoint) -> list[np.ndarray]:
        """Per order the (n_n,) complex amplitudes of every DOF, the order's own included
        (Firrone & Zucca eq. 9): what a reduced body's recovery matrix takes."""
        h = self.harmonics
        lin = self.condensed(point)
        Xc = h.to_complex(x.reshape(self.dofs.size, h.n_coeffs))
        out = []
        for k, (o, n) in enumerate(zip(h.orders, self.linear.sizes)):
            X = np.zeros(n, dtype=complex)
            X[self.dofs] = Xc[o]
            X[condensed_dofs(self.others, self.linear.n_dof, n)] = lin.z[k] - lin.Y[k] @ Xc[o]
            out.append(X)
        return out

    def recover(self, x: np.ndarray, point: OperatingPoint) -> np.ndarray:
        """(n_dof, ncoeff) coefficients of every shared DOF (Firrone & Zucca eq. 9)."""
        h = self.harmonics
        n = self.linear.n_dof
        X = self.recover_orders(x, point)
        return h.from_complex({o: X[k][:n] for k, o in enumerate(h.orders)}, (n,))

    def energy_balance(self, x: np.ndarray, point: OperatingPoint) -> dict[str, float]:
        """Work per cycle, J: excitation, viscous, contacts (friction + normal).

        Over a period a force ``Re(F e^{i n w t})`` does on ``Re(X e^{i n w t})`` the work
        ``int f dx = -pi n Im(F^H X)``, and a damper C dissipates ``pi w n^2 X^H C X``; the
        static order does none. Every DOF of every order counts (modal ones too)."""
        X = self.recover_orders(x, point)
        F, _ = self.forces(point)
        w_ext = w_visc = 0.0
        for o, Xk, Fk, Ck in zip(self.harmonics.orders, X, F, self.linear.C):
            if o > 0:
                w_ext += -np.pi * o * float(np.imag(np.vdot(Fk, Xk)))
                w_visc += np.pi * point.omega * o**2 * float(np.real(np.vdot(Xk, Ck @ Xk)))
        resp = self.contact_response(x, point)
        w_fric = float(sum(r.dissipation.sum() for r in resp))
        w_norm = float(sum(r.normal_work.sum() for r in resp))
        return {"excitation": w_ext, "viscous": w_visc, "friction": w_fric, "normal": w_norm}

    def linear_guess(self, point: OperatingPoint, stuck: bool = False) -> np.ndarray:
        """Linear response, DOF-major: contacts removed (free system) or, with
        ``stuck``, replaced by their stick stiffness (kt, and kn for the variable
        laws). A singular free system (a body held only by its contacts) falls
        back to the stuck one.

        Solved order by order on the condensed complex blocks (no factorization of the
        whole real system); an order counts as singular when LAPACK's estimate of its
        reciprocal condition number is below 1e-12. Cached per point."""
        key = ("guess", point, stuck)
        hit = self._cache.get(key)
        if hit is not None:
            return hit.copy()
        lin = self.condensed(point)
        h = self.harmonics
        if lin.S.shape[1] == 0:
            return np.zeros(0)
        X = None if stuck else solve_orders(lin.S, lin.F)
        if X is None:
            S = lin.S + self._stick_stiffness()
            X = solve_orders(S, lin.F)
            if X is None:  # singular even stuck (e.g. uncoupled laws at order 0)
                X = np.array([np.linalg.lstsq(A, b, rcond=None)[0] for A, b in zip(S, lin.F)])
        x = h.real_vector(X).ravel()
        self._cache.put(key, x, x.nbytes)
        return x.copy()

    def _stick_stiffness(self) -> np.ndarray:
        """(n_orders, nc, nc) :meth:`stick_stiffness` of every order on the contact DOFs."""
        key = ("stick",)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        out = np.array([self.stick_stiffness(o, self.dofs) for o in self.harmonics.orders])
        self._cache.put(key, out, out.nbytes)
        return out

    def stick_stiffness(self, order: int, dofs: np.ndarray | None = None) -> np.ndarray:
        """Complex B_n^H K_stick B_n of harmonic ``order`` on ``dofs`` (default: all n_dof
        shared DOFs): the contacts stuck, kt per tangential direction and kn normal for
        the variable-normal laws; N/m."""
        cols = np.arange(self.linear.n_dof) if dofs is None else dofs
        out = np.zeros((cols.size, cols.size), dtype=complex)
        for c, B in zip(self.contacts, self._B):
            k = c.elements.stuck_stiffness()
            # sparse: a point's rows touch its two nodes only (dense, the product cost
            # N_dof^2 x rows: 1.5 s at 2 x 120 pairs)
            Bc = sp.csr_matrix(B[order][:, cols])
            out += (Bc.conj().T @ sp.diags(k.ravel()) @ Bc).toarray()
        return out


#: Bytes the per-point cache of a HarmonicBalance may hold (dense condensed matrices of a
#: full-scale model take tens of MB each), the model's reordered linear part included; memory
#: estimates read it.
CACHE_LIMIT = 512 * 2**20


class _Cache:
    """Results per operating point, bounded by CACHE_LIMIT bytes: the oldest go first. Pinned
    entries (per-model data every point needs) count against the bound but stay."""

    LIMIT = CACHE_LIMIT

    def __init__(self):
        self._data: dict = {}
        self._pinned: dict = {}
        self._bytes = 0

    def get(self, key):
        return (self._data.get(key) or self._pinned.get(key, (None, 0)))[0]

    def put(self, key, value, nbytes: int, pinned: bool = False) -> None:
        store = self._pinned if pinned else self._data
        if key in store:
            self._bytes -= store.pop(key)[1]
        while self._data and self._bytes + nbytes > self.LIMIT:
            self._bytes -= self._data.pop(next(iter(self._data)))[1]
        store[key] = (value, nbytes)
        self._bytes += nbytes
