"""The reduced model of one body at one nodal diameter: its record (matrices, masters,
recovery, loads), its HDF5 file and the content key it is kept under.

Reduced coordinates q = [master DOFs ; modal amplitudes] (``craig_bampton``; ``modal``: modal
amplitudes only). Models are stored in HDF5 (never pickle) and reused when the content key of
their inputs matches (``bodies.reduce_body``). The key hashes the mode selection, whose
defaults are here (DEFAULT_MODES, CUTOFF, INTEREST) so that a model's key and the reductions
that make it agree.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from numpy.typing import NDArray

from . import cyclic, fem
from .fem import Damping, IntArray, Material

#: A reduced model's lowest frequency below this fraction of its highest is a rigid mode:
#: modal damping's eigenvalue share (fem.RIGID_SHARE) as a frequency ratio
RIGID = fem.RIGID_SHARE ** 0.5

#: Bump when the stored layout or the algorithm changes (invalidates caches).
#: 2: reduced load vectors (``ReducedModel.loads``, the centrifugal load at ND 0).
FORMAT_VERSION = 2
#: Name of the centrifugal load (per unit Omega^2) in ``ReducedModel.loads``.
CENTRIFUGAL = "centrifugal"
#: Default fixed-interface mode selection: "auto" keeps every mode below CUTOFF x f_ref, with
#: f_ref the INTEREST-th fixed-interface frequency (or a given f_max). An integer keeps that many.
DEFAULT_MODES = "auto"
#: Cut-off multiplier, chosen from measurement (``microslip bench reduction --cb``): the
#: CB error of the first ten frequencies behaves like (f_10 / f_cut)^2. Max error over the first
#: ten per ND, cut-off at c x the 10th fixed-interface frequency:
#:   c      annular sector (test model, ND 0-3)    blisk sector (default, ND 0/1/12/24)
#:   3.0    1.4e-3 (45-51 modes)                   2.6e-3 (27-32 modes)
#:   3.5    7.1e-4 (55-67 modes)                   1.6e-3 (33-41 modes)
#:   4.0    4.1e-4 (69-85 modes)                   6.4e-4 (40-51 modes)
#:   5.0    1.6e-4 (97-119 modes)                  1.9e-4 (56-79 modes)
#: so 4.0 meets the 0.1 % goal on both with a margin of 1.5-2.5. The 10th fixed-interface
#: frequency is above the 10th free-interface one (a constraint raises every eigenvalue), so the
#: cut-off is at least 4 x the highest frequency of interest.
CUTOFF = 4.0
#: Number of frequencies of interest per ND when no f_max is given.
INTEREST = 10

@dataclass(frozen=True, eq=False)
class ReducedModel:
    """Reduced model of one body at one nodal diameter.

    stiffness, mass: (r, r) dense, float64 or complex128 Hermitian [N/m], [kg]
        (modal block in mass-normalised units).
    damping_spec: linear damping applied to the reduced model (``damping`` gives the matrix).
    master_nodes: (n_m,) global mesh point indices (nodes, or points averaging nodes: a
        contact grid apart from the mesh, ``AveragedMasters``); master_coordinates (n_m, 3)
        [m].
    n_modes: fixed-interface (CB) or normal (modal) modes kept; r = 3 n_m + n_modes.
    mode_frequencies: (n_modes,) [Hz] of those modes.
    patches: contact-patch name -> (k,) global node indices of that patch in this body
        (a subset of master_nodes).
    recovery_nodes: (p,) global node indices; recovery: (p, 3, r), u(node) = recovery @ q.
    nodal_diameter, sectors: None for a body without cyclic symmetry.
    loads: load name -> (r,) reduced load vector, dtype of the model (complex at 0 < h < Ns/2),
        the generalized force on q of an FE load on the body DOFs (q^H loads[name] is its
        virtual work). "centrifugal" (``CENTRIFUGAL``): per unit Omega^2, N/(rad/s)^2 on the
        master DOFs (the modal entries in the units of the mass-normalised modes), present at
        ND 0 of a cyclic body and for a body without cyclic symmetry.
    region_dofs: (n_b,) body DOFs of a region whose stiffness may deviate (a mistuned
        blade; empty: none); region: (n_b, r) the rows of the basis there, u[region_dofs] =
        region @ q (the cyclic expansion included: a right-face DOF's row carries its
        phase), what an annulus projects the region's stiffness with; region_stiffness:
        (n_b, n_b) sparse [N/m] the region's own stiffness there (``fem.region_stiffness``),
        or None.
    key: content hash of everything that produced the reduction (the damping spec is a
        separate field, applied without re-reducing). A mass study scales the mass by a
        multiplier in the harmonic balance (``LinearDynamics.mass``): exact, since re-reducing
        with density s rho spans the same subspace.
    """

    body: str
    method: str
    stiffness: NDArray
    mass: NDArray
    master_nodes: IntArray
    master_coordinates: NDArray[np.float64]
    n_modes: int
    mode_frequencies: NDArray[np.float64]
    recovery_nodes: IntArray
    recovery: NDArray
    nodal_diameter: int | None = None
    sectors: int | None = None
    patches: Mapping[str, IntArray] = field(default_factory=dict)
    damping_spec: Damping | None = None
    key: str = ""
    loads: Mapping[str, NDArray] = field(default_factory=dict)
    region_dofs: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    region: NDArray = field(default_factory=lambda: np.zeros((0, 0)))
    region_stiffness: Any = None

    # --- sizes and maps the harmonic balance needs ---------------------------------------

    @property
    def n_masters(self) -> int:
        """Number of master DOFs (3 per master node)."""
        return 3 * len(self.master_nodes)

    @property
    def size(self) -> int:
        return int(self.stiffness.shape[0])

    @property
    def master_dof_nodes(self) -> IntArray:
        """(n_masters,) global node index of each master coordinate."""
        return np.repeat(self.master_nodes, 3)

    @property
    def master_dof_directions(self) -> IntArray:
        """(n_masters,) Cartesian direction 0/1/2 (x/y/z) of each master coordinate."""
        return np.tile(np.arange(3, dtype=np.int64), len(self.master_nodes))

    def dof_index(self, nodes: Sequence[int] | IntArray) -> IntArray:
        """(k, 3) reduced-coordinate indices of the x, y, z DOFs of master ``nodes``."""
        nodes = np.asarray(nodes, dtype=np.int64).ravel()
        order = np.argsort(self.master_nodes)
        pos = np.searchsorted(self.master_nodes, nodes, sorter=order)
        pos = order[np.minimum(pos, len(order) - 1)] if len(order) else pos
        if len(order) == 0 or np.any(self.master_nodes[pos] != nodes):
            missing = nodes if len(order) == 0 else nodes[self.master_nodes[pos] != nodes]
            raise ValueError(
                f"nodes {missing[:8].tolist()} are not masters of the reduced model of "
                f"{self.body!r}"
            )
        return 3 * pos[:, None] + np.arange(3)

    def patch_dofs(self, name: str) -> IntArray:
        """(k, 3) reduced-coordinate indices of a contact patch's nodes in this body."""
        if name not in self.patches:
            raise ValueError(f"patch {name!r} is not in this model; has {sorted(self.patches)}")
        return self.dof_index(self.patches[name])

    def recover(self, q: NDArray, nodes: Sequence[int] | IntArray | None = None) -> NDArray:
        """Displacements (p, 3) (or (p, 3, k) for q (r, k)) of recovery nodes from q."""
        R = self.recovery
        if nodes is not None:
            nodes = np.asarray(nodes, dtype=np.int64).ravel()
            pos = np.searchsorted(self.recovery_nodes, nodes)
            pos = np.minimum(pos, max(len(self.recovery_nodes) - 1, 0))
            if len(self.recovery_nodes) == 0 or np.any(self.recovery_nodes[pos] != nodes):
                raise ValueError(f"nodes={nodes[:8].tolist()}: not all are recovery nodes")
            R = R[pos]
        return R @ q

    @cached_property
    def damping(self) -> NDArray | None:
        """(r, r) damping matrix [N s/m] from ``damping_spec``, or None; formed once (modal
        ratios take an eigendecomposition: a whole disk's annulus, thousands of coordinates,
        is asked at every harmonic order)."""
        return fem.damping_matrix(self.stiffness, self.mass, self.damping_spec,
                                  lambda: self._modes)

    @cached_property
    def _modes(self) -> tuple[NDArray, NDArray]:
        """(lam, Phi) of (K, M), masters free: the modal damping's modes, whose eigenvalues
        the frequencies then reuse (a whole disk's annulus: one eigendecomposition of its
        thousands of coordinates per pattern, not two)."""
        return sla.eigh(self.stiffness, self.mass)

    def matrices(self, conjugate: bool = False) -> tuple[NDArray, NDArray, NDArray]:
        """(K, M, C) dense; C zero if undamped; complex conjugates for a backward wave."""
        C = self.damping
        C = np.zeros_like(self.stiffness) if C is None else C
        if conjugate:
            return self.stiffness.conj(), self.mass.conj(), C.conj()
        return self.stiffness, self.mass, C

    # --- derived models ------------------------------------------------------------------

    def with_damping(self, damping: Damping | None) -> ReducedModel:
        """Same reduction with another linear damping spec (no re-reduction)."""
        return replace(self, damping_spec=damping)

    def frequencies(self, k: int | None = None) -> NDArray[np.float64]:
        """Lowest natural frequencies [Hz] of the reduced model (free masters)."""
        f = self._frequencies
        return f if k is None else f[:k]

    @cached_property
    def _frequencies(self) -> NDArray[np.float64]:
        lam = self.__dict__["_modes"][0] if "_modes" in self.__dict__ else \
            np.linalg.eigvalsh(_generalized(self.stiffness, self.mass))
        return np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)

    @property
    def has_rigid_mode(self) -> bool:
        """Whether the model (masters free) moves as a rigid body, its own stiffness not
        holding it (a damper, a blade held in its slot by its contacts): its lowest
        frequency below RIGID of its highest (round-off puts a rigid mode's near 1e-8 of
        it; a body's first elastic mode lies far above 1e-5)."""
        f = self._frequencies
        return bool(f[0] < RIGID * f[-1])

    # --- HDF5 ----------------------------------------------------------------------------

    def save(self, path: str | Path, group: str = "/") -> Path:
        """Write to an HDF5 file (group ``group``), replacing what is there."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with h5py.File(path, "a") as f:
            self.save_into(f, group)
        return path

    def save_into(self, f: h5py.File, group: str = "/") -> None:
        """Write into the open HDF5 file ``f`` (group ``group``), replacing what is
        there."""
        if group != "/" and group in f:
            del f[group]
        g = f.require_group(group)
        for name in list(g):
            del g[name]
        for name in ("stiffness", "mass", "master_nodes", "master_coordinates",
                     "mode_frequencies", "recovery_nodes", "recovery"):
            g.create_dataset(name, data=np.asarray(getattr(self, name)))
        pg = g.create_group("patches")
        for name, nodes in self.patches.items():
            pg.create_dataset(name, data=np.asarray(nodes, dtype=np.int64))
        lg = g.create_group("loads")
        for name, vector in self.loads.items():
            lg.create_dataset(name, data=np.asarray(vector))
        if len(self.region_dofs):  # (only where there is one: older files have none)
            g.create_dataset("region_dofs", data=np.asarray(self.region_dofs, np.int64))
            g.create_dataset("region", data=np.asarray(self.region))
        if self.region_stiffness is not None:
            K = sp.csr_matrix(self.region_stiffness)
            rg = g.create_group("region_stiffness")
            for name in ("data", "indices", "indptr"):
                rg.create_dataset(name, data=getattr(K, name))
        g.attrs["format_version"] = FORMAT_VERSION
        g.attrs["body"] = self.body
        g.attrs["method"] = self.method
        g.attrs["n_modes"] = self.n_modes
        g.attrs["nodal_diameter"] = -1 if self.nodal_diameter is None else self.nodal_diameter
        g.attrs["sectors"] = -1 if self.sectors is None else self.sectors
        g.attrs["key"] = self.key
        spec = self.damping_spec
        g.attrs["damping"] = json.dumps(
            None if spec is None else [spec.rayleigh_alpha, spec.rayleigh_beta,
                                       list(spec.modal_ratios)]
        )

    @classmethod
    def load(cls, path: str | Path, group: str = "/") -> ReducedModel:
        """Read a model written by ``save``."""
        with h5py.File(path, "r") as f:
            g = f[group]
            if int(g.attrs["format_version"]) != FORMAT_VERSION:
                raise ValueError(f"{path}: format_version {g.attrs['format_version']} != "
                                 f"{FORMAT_VERSION}")
            arrays = {name: g[name][()] for name in (
                "stiffness", "mass", "master_nodes", "master_coordinates",
                "mode_frequencies", "recovery_nodes", "recovery")}
            patches = {name: g["patches"][name][()] for name in g["patches"]}
            loads = {name: g["loads"][name][()] for name in g["loads"]}
            if "region_dofs" in g:
                arrays |= {"region_dofs": g["region_dofs"][()], "region": g["region"][()]}
            if "region_stiffness" in g:
                rg, n = g["region_stiffness"], len(arrays["region_dofs"])
                arrays["region_stiffness"] = sp.csr_matrix(
                    (rg["data"][()], rg["indices"][()], rg["indptr"][()]), shape=(n, n))
            spec = json.loads(g.attrs["damping"])
            nd, ns = int(g.attrs["nodal_diameter"]), int(g.attrs["sectors"])
            return cls(
                body=str(g.attrs["body"]),
                method=str(g.attrs["method"]),
                n_modes=int(g.attrs["n_modes"]),
                nodal_diameter=None if nd < 0 else nd,
                sectors=None if ns < 0 else ns,
                patches=patches,
                damping_spec=None if spec is None else Damping(spec[0], spec[1], tuple(spec[2])),
                key=str(g.attrs["key"]),
                loads=loads,
                **arrays,
            )


def _generalized(K: NDArray, M: NDArray) -> NDArray:
    """L^-1 K L^-H with M = L L^H: the standard Hermitian form of (K, M)."""
    L = np.linalg.cholesky(0.5 * (M + M.conj().T))
    X = np.linalg.solve(L, 0.5 * (K + K.conj().T))
    A = np.linalg.solve(L, X.conj().T)
    return 0.5 * (A + A.conj().T)


def _hash(obj: object) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def nodes_digest(nodes: NDArray) -> str:
    a = np.ascontiguousarray(np.asarray(nodes, dtype=np.int64))
    return hashlib.sha256(a.tobytes()).hexdigest()


def reduction_key(
    model: cyclic.SectorModel,
    method: str,
    master_nodes: IntArray,
    n_modes: int | str,
    recovery_nodes: IntArray,
    patches: Mapping[str, IntArray] | None = None,
    cutoff: float = CUTOFF,
    f_max: float | None = None,
    loads: Iterable[str] = (),
    averaged_digest: str = "",
    region_dofs: IntArray = (),
) -> str:
    """Content hash of the inputs of a reduction (mesh, body, material, order, constraints,
    ND, masters, modes, recovery nodes, patches, names of the projected loads, format
    version; ``averaged_digest``: that of the averaged masters, ``AveragedMasters.digest``;
    ``region_dofs``: a mistuned region's DOFs, whose basis rows are kept).
    Load vectors enter by name only: those ``reduce_body`` projects are functions of mesh,
    body, material and order, already in the hash."""
    body = model.body
    key = model_key(body.mesh_hash, body.body, body.order, body.material, model.clamped_nodes,
               model.nodal_diameter, method, master_nodes, n_modes, recovery_nodes, patches,
               cutoff, f_max, loads, model.supports)
    key = _hash([key, averaged_digest]) if averaged_digest else key
    # (a region enters only where there is one: the keys of models without stay as they were)
    return _hash([key, nodes_digest(region_dofs)]) if len(region_dofs) else key


def model_key(mesh_hash: str, body: str, order: int, material: Material, clamped: IntArray,
         nodal_diameter: int | None, method: str, master_nodes: IntArray, n_modes: int | str,
         recovery_nodes: IntArray, patches: Mapping[str, IntArray] | None,
         cutoff: float = CUTOFF, f_max: float | None = None,
         loads: Iterable[str] = (), supports: Sequence[Any] = ()) -> str:
    """Content hash of what a reduced model is made of (its inputs, by value or digest)."""
    # (supports enter only where there are some: the keys of models without stay as they were)
    held = {"supports": [s.digest for s in supports]} if supports else {}
    return _hash(held | {
        "format": FORMAT_VERSION,
        "mesh": mesh_hash,
        "body": body,
        "order": int(order),
        "material": material.as_tuple(),
        "clamped": nodes_digest(np.unique(clamped)),
        "nd": nodal_diameter,
        "method": method,
        "masters": nodes_digest(master_nodes),
        "modes": mode_selection(n_modes, cutoff, f_max),
        "recovery": nodes_digest(np.unique(recovery_nodes)),
        "patches": {k: nodes_digest(v) for k, v in (patches or {}).items()},
        "loads": sorted(loads),
    })


# --- the reductions ---------------------------------------------------------------------


def mode_selection(n_modes: int | str, cutoff: float, f_max: float | None) -> object:
    """What the mode selection is, for the content hash."""
    if isinstance(n_modes, str):
        return [n_modes, float(cutoff), None if f_max is None else float(f_max), INTEREST]
    return int(n_modes)


def reference_frequency(models: Iterable[ReducedModel]) -> float | None:
    """The highest INTEREST-th (10th) fixed-interface frequency [Hz] among ``models`` (None if
    none has that many modes): the top of the range they resolve, the f_max to give a body whose
    own modes lie far above it (the free damper beside the disk)."""
    f = [m.mode_frequencies[INTEREST - 1] for m in models if m.n_modes >= INTEREST]
    return float(max(f)) if f else None
