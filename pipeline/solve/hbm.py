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
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from microslip.fourier import Harmonics
from microslip.laws.coulomb import ContactResponse
from microslip.laws.interface import ContactSet
from microslip.solve import modal_condensation as modal
from microslip.solve.component_condensation import ComponentForm
from microslip.solve.condensation import (
    Condensed,
    Reordered,
    condense,
    condensed_dofs,
    solve_orders,
)
from microslip.solve.jacobian import BalanceJacobian, PointBlocks, Preconditioner
from microslip.solve.linear import (
    Excitation,
    LinearDynamics,
    OperatingPoint,
)

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
        lin = self.reordered()
        F, dF = self.forces(point, parameter)
        if parameter == "mass":  # a mass continuation: every point another multiplier
            self._cache.put(("mass varies",), True, 0, pinned=True)
        form = self._form(point) if parameter in modal.PARAMETERS \
            and point.xi is None else None
        if form is not None:
            out = form.condensed(point.omega, lin.take(F),
                                 None if dF is None else lin.take(dF), parameter)
            self._cache.put(key, out, out.nbytes)
            return out
        dD = lin.linear.d_dynamic_stiffness(point, parameter) if parameter else None
        # a nonlinear mode's point (xi) keeps the factors: it needs the derivative by xi too
        out = condense(lin.linear.dynamic_stiffness(point), lin.take(F), self.dofs.size, dD,
                       None if dF is None else lin.take(dF), keep_factors=point.xi is not None)
        self._cache.put(key, out, out.nbytes)
        return out

    def _form(self, point: OperatingPoint) -> modal.ModalForm | ComponentForm | None:
        """The form of the modal or the component route at the point's mass multiplier
        (None: the Schur complement over every other DOF), made once per multiplier and
        pinned in the cache, the last multiplier's only (a mass family's whole disk: each
        form holds its modes)."""
        key, s = ("form",), point.mass_multiplier
        hit = self._cache.get(key)
        if hit is not None and hit[0] != s and self._cache.get(("mass varies",)):
            return None  # (a form per point of a mass continuation: eigendecompositions)
        if hit is None or hit[0] != s:
            form = self._route(point)
            hit = (s, form)
            self._cache.put(key, hit, 0 if form is None else form.nbytes, pinned=True)
        return hit[1]

    def _route(self, point: OperatingPoint) -> modal.ModalForm | ComponentForm | None:
        """The cheapest route per iterate where it saves MODAL_GAIN x the Schur complement's
        work of MODAL_FROM or more: the components' (the large ones' D_ii factored, S made
        only when asked), else the modal one (the receptance), where it applies."""
        lin, nc = self.reordered().linear, self.dofs.size
        masses = lin.mass(point)
        if nc == 0 or not any(o > 0 for o in lin.orders):
            return None
        parts = modal.component_parts(lin, nc, masses)
        schur, by_modes = modal.route_costs(lin, nc, masses, parts[0])
        by_parts = ComponentForm.cost(parts[0])
        if schur < modal.MODAL_FROM or min(by_modes, by_parts) * modal.MODAL_GAIN > schur:
            return None
        form = modal.ModalForm.of(lin, nc, masses, always=True, parts=parts) \
            if by_modes < by_parts else None
        if form is None and by_parts * modal.MODAL_GAIN <= schur:
            return ComponentForm.of(lin, nc, masses, parts)
        return form

    def reordered(self) -> Reordered:
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
            X[condensed_dofs(self.others, self.linear.n_dof, n)] = lin.recover(k, Xc[o])
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
        out = sp.csr_matrix((cols.size, cols.size), dtype=complex)
        for c, B in zip(self.contacts, self._B):
            k = c.elements.stuck_stiffness()
            # sparse: a point's rows touch its two nodes only (dense, the product cost
            # N_dof^2 x rows: 1.5 s at 2 x 120 pairs), and summed sparse (a whole disk's
            # hundreds of contacts, each added densely, took 4 s at 48 blades)
            Bc = sp.csr_matrix(B[order][:, cols])
            out = out + Bc.conj().T @ sp.diags(k.ravel()) @ Bc
        return out.toarray()


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
