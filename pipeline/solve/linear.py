"""The linear part of the harmonic balance: per harmonic order the structure's K_n, M_n, C_n
(:class:`LinearDynamics`; real, or complex Hermitian from the cyclic-symmetry stage), the
external forces (:class:`Excitation`: per order, with the centrifugal load of a rotating
model) and the operating point the balance is solved at (:class:`OperatingPoint`: the
scalar parameters continuation follows, ``PARAMETERS``).

frequency   w, rad/s
excitation  multiplier of the dynamic (n >= 1) external forces; static loads stay
mass        multiplier s of ``LinearDynamics.mass_part``: ``M(s) = M + (s - 1) M_part``
preload     multiplier of every contact's ``n0`` (``N0`` or ``kn * interference``)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from microslip.fourier import Harmonics

PARAMETERS = ("frequency", "excitation", "mass", "preload")


@dataclass(frozen=True)
class OperatingPoint:
    """Values of the scalar parameters at which the balance is solved.

    omega: angular frequency [rad/s]; excitation, mass_multiplier, preload: dimensionless
    multipliers (see ``PARAMETERS``; a continuation parameter name maps to its field); xi:
    the self-excitation ``-xi M dq/dt`` of a nonlinear mode [1/s] (``solve.nonlinear_modes``:
    a float, 0.0 included, makes the point autonomous; None for a forced response).
    """

    omega: float
    excitation: float = 1.0
    mass_multiplier: float = 1.0
    preload: float = 1.0
    xi: float | None = None

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
            made: dict = {}  # orders with the same matrices share theirs
            for M, Mp, scaled in zip(self.M, self.M_part, self._nonzero[1]):
                key = (id(M), id(Mp))
                if key not in made:
                    made[key] = M + (s - 1.0) * Mp if scaled else M
            self._scaled[s] = tuple(made[id(M), id(Mp)] for M, Mp in zip(self.M,
                                                                          self.M_part))
        return self._scaled[s]

    @cached_property
    def _nonzero(self) -> tuple[tuple[bool, ...], tuple[bool, ...]]:
        """Per order whether C and M_part have any nonzero entry: zero ones are skipped
        (an undamped body, a cyclic body no mass multiplier scales)."""
        return (tuple(bool(np.any(C)) for C in self.C),
                tuple(bool(np.any(Mp)) for Mp in self.M_part))

    def dynamic_stiffness(self, point: OperatingPoint) -> tuple[np.ndarray, ...]:
        """Per order D_n = K_n - (n w)^2 M_n + i n w (C_n - xi M_n) at the point; order 0 is
        K_0 itself (real if stored real: read it, do not write it)."""
        w, damped, masses = point.omega, self._nonzero[0], self.mass(point)
        D = tuple(K if o == 0 else _combined(M, -((o * w) ** 2), K, C if d else None, o * w)
                  for o, K, M, C, d in zip(self.orders, self.K, masses, self.C, damped))
        if not point.xi:
            return D
        return tuple(Dk if o == 0 else Dk - 1j * o * w * point.xi * M
                     for o, Dk, M in zip(self.orders, D, masses))

    def d_dynamic_stiffness(self, point: OperatingPoint, parameter: str
                            ) -> tuple[np.ndarray | None, ...] | None:
        """Per order dD_n / d parameter (None at order 0, where D does not depend on w or
        the mass), or None where no order's D depends on it. Besides ``PARAMETERS``,
        "xi": the self-excitation of a nonlinear mode."""
        w, damped, xi = point.omega, self._nonzero[0], point.xi
        if parameter == "frequency":
            masses = self.mass(point)
            out = tuple(None if o == 0 else _combined(M, -2.0 * o**2 * w, None,
                                                      C if d else None, o)
                        for o, M, C, d in zip(self.orders, masses, self.C, damped))
            if xi:  # d/dw of -i n w xi M_n
                out = tuple(d if o == 0 else d - 1j * o * xi * M
                            for o, d, M in zip(self.orders, out, masses))
            return out
        if parameter == "mass":  # -(n w)^2 M_part, and -i n w xi M_part at a mode's level
            return tuple(None if o == 0 else Mp * (-((o * w) ** 2) - (1j * o * w * xi if xi
                                                                       else 0.0))
                         for o, Mp in zip(self.orders, self.M_part))
        if parameter == "xi":
            return tuple(None if o == 0 else -1j * o * w * M
                         for o, M in zip(self.orders, self.mass(point)))
        return None


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
