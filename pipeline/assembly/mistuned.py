"""The whole bladed disk, tuned or mistuned, as the reduced bodies of the full disk
(``geometry.full_disk``'s names: a cyclic body one body of every sector, another body N
copies "<body>#s", patches and node sets "<name>#s"), built from the sector's reductions at
every nodal diameter (``annulus.Annulus``) without the full disk's FE model: what ``join``
couples into the harmonic balance with every sector's contacts present, and the case's
spec on every sector (the engine order's phase on each sector's loads, each sector's
outputs)."""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import scipy.sparse as sp

from microslip.fe.reduced_model import CENTRIFUGAL, ReducedModel
from microslip.geometry.full_disk import disk_node_map, sector_count
from microslip.geometry.mesh import Mesh, rotation_z

from .annulus import Annulus, SectorND, as_real
from .spec import AssemblySpec, NodalLoad, Output


@dataclass(frozen=True, eq=False)
class Mistuning:
    """Blade-to-blade mistuning of a cyclic body: sector s's region (``ReducedModel.region_dofs``
    of every ND's reduction) stiffer by ``deviation[s]`` (a fraction: -0.03 is 3 % softer);
    of a body of separate blades (copied per sector): copy s's whole stiffness, exactly
    (a reduction of K (1 + d) is that of K, its stiffness times 1 + d);
    ``region_stiffness``: (n_b, n_b) [N/m] the region's stiffness on those DOFs (its
    Young's modulus' share: K(2E) - K(E) over the region's elements); None: the one the
    reduction kept (``ReducedModel.region_stiffness``)."""

    body: str
    deviation: tuple[float, ...]
    region_stiffness: Any = None

    def __post_init__(self):
        d = np.asarray(self.deviation, dtype=float)
        if d.ndim != 1 or not np.all(np.isfinite(d)) or np.any(d <= -1):
            raise ValueError(f"mistuning.deviation = {self.deviation!r}: finite fractions > -1 "
                             "(one per sector)")


def annulus_bodies(sector: Mesh, models: Mapping[str, Mapping[int, ReducedModel]],
                   mistuning: Mistuning | None = None) -> dict[str, dict[int, ReducedModel]]:
    """The full disk's reduced bodies (name -> {0: model}) from the sector's (body -> ND
    -> model; a cyclic body reduced at every ND 0 .. N/2)."""
    return TunedDisk.of(sector, models).bodies_with(mistuning)


@dataclass(frozen=True, eq=False)
class TunedDisk:
    """What every mistuning pattern of one sector case shares, formed once: the tuned full
    disk's bodies (each cyclic body one annulus body, the others turned copies) and each
    cyclic body's annulus, whose region energy E_0 is formed at the first pattern."""

    sector: Mesh
    per_nd: Mapping[str, Mapping[int, ReducedModel]]  # the cyclic bodies' reductions
    bodies: dict[str, dict[int, ReducedModel]]
    annuli: dict[str, Annulus]

    @classmethod
    def of(cls, sector: Mesh, models: Mapping[str, Mapping[int, ReducedModel]]) -> TunedDisk:
        N = sector_count(sector)
        node_map = disk_node_map(sector)
        bodies, annuli = {}, {}
        for body, per_nd in models.items():
            if body in sector.cyclic:
                annuli[body] = _annulus(body, per_nd, N)
                bodies[body] = {0: _annulus_body(body, per_nd, annuli[body], node_map)}
            else:
                m = per_nd[min(per_nd)]
                for s in range(N):
                    bodies[f"{body}#{s}"] = {0: _turned_copy(m, f"{body}#{s}", s, N, node_map)}
        cyclic = {b: models[b] for b in annuli}
        return cls(sector, cyclic, bodies, annuli)

    def bodies_with(self, mistuning: Mistuning | None) -> dict[str, dict[int, ReducedModel]]:
        """The bodies with ``mistuning``'s pattern (None: tuned): only its body's
        stiffness changes."""
        if mistuning is None:
            return self.bodies
        body = mistuning.body
        if body not in self.annuli:
            return self._copies_with(mistuning)
        a, per_nd = self.annuli[body], self.per_nd[body]
        _check_regions(body, per_nd, a.sectors, mistuning)
        if len(mistuning.deviation) != a.sectors:
            raise ValueError(f"mistuning.deviation: {len(mistuning.deviation)} values for "
                             f"{a.sectors} sectors")
        K = a.mistuned_stiffness(mistuning.deviation, self._region_energy(body, mistuning))
        tuned = self.bodies[body][0]
        return {**self.bodies, body: {0: replace(tuned, stiffness=K,
                                                 key=_key([tuned.key], mistuning))}}

    def _copies_with(self, mistuning: Mistuning) -> dict[str, dict[int, ReducedModel]]:
        """The bodies with each copy s of a body of separate blades stiffer by
        ``deviation[s]`` (its damping follows from the scaled stiffness)."""
        body, d = mistuning.body, mistuning.deviation
        copies = [f"{body}#{s}" for s in range(len(d))]
        if any(c not in self.bodies for c in copies) or f"{body}#{len(d)}" in self.bodies:
            raise ValueError(f"mistuning.body = {body!r}: neither a cyclic body nor one copy "
                             f"per blade of {len(d)}; cyclic bodies: "
                             f"{sorted(self.sector.cyclic)}")
        if mistuning.region_stiffness is not None:
            raise ValueError(f"mistuning.body = {body!r}: separate blades deviate whole; a "
                             "region stiffness is a cyclic body's")
        out = dict(self.bodies)
        for c, ds in zip(copies, d):
            m = self.bodies[c][0]
            if ds:  # (a tuned copy keeps its model, its damping and modes formed)
                out[c] = {0: replace(m, stiffness=m.stiffness * (1.0 + ds),
                                     key=_key([m.key], Mistuning(body, (ds,))))}
        return out

    def _region_energy(self, body: str, mistuning: Mistuning) -> np.ndarray:
        """E_0 of the reduction's region stiffness, formed once per body; of a given one,
        each time."""
        a = self.annuli[body]
        if mistuning.region_stiffness is not None:
            return a.region_energy(mistuning.region_stiffness)
        cache = self.__dict__.setdefault("_energies", {})
        if body not in cache:
            cache[body] = a.region_energy(self.per_nd[body][0].region_stiffness)
        return cache[body]


def annulus_spec(spec: AssemblySpec, sectors: int, cyclic_bodies: Sequence[str]
                 ) -> AssemblySpec:
    """The sector's spec on every sector of the full disk: each patch's contacts (their
    march started at sector s's own excitation's start, ``-EO s phi``), each
    load with the engine order's phase ``harmonic EO s phi`` on sector s, each output per
    sector ("<name>#s"), the centrifugal and mass bodies' copies."""
    phi = 2.0 * np.pi / sectors
    every = range(sectors)

    def bodies(names):
        return tuple(b if b in cyclic_bodies else f"{b}#{s}" for b in names for s in every
                     if b not in cyclic_bodies or s == 0)

    return replace(
        spec,
        contacts=tuple(replace(c, patch=f"{c.patch}#{s}",
                               start_phase=c.start_phase - spec.engine_order * s * phi)
                       for s in every for c in spec.contacts),
        loads=tuple(NodalLoad(f"{x.node_set}#{s}", _turned(x.direction, s * phi),
                              x.amplitude, x.harmonic,
                              x.phase + x.harmonic * spec.engine_order * s * phi, x.spread)
                    for s in every for x in spec.loads),
        outputs=tuple(Output(f"{o.name}#{s}", f"{o.node_set}#{s}", _turned(o.direction,
                                                                          s * phi))
                      for s in every for o in spec.outputs),
        centrifugal=bodies(spec.centrifugal), mass_bodies=bodies(spec.mass_bodies))


def _turned(direction, angle: float):
    """A load's or output's direction on the sector turned by ``angle``: x, y and vectors
    (the global frame) turned with it; z and the node's own radial, tangential and axial
    directions as they are (each node reads them at its own place)."""
    if isinstance(direction, str) and direction not in ("x", "y"):
        return direction
    d = np.eye(3)["xyz".index(direction)] if isinstance(direction, str) else np.asarray(direction)
    return tuple(float(v) for v in rotation_z(angle) @ d)


def _annulus(body: str, per_nd: Mapping[int, ReducedModel], N: int) -> Annulus:
    """The tuned annulus of a cyclic body's reductions (with the region's rows where they
    were kept), checked: every ND present, one damping ratio, the same masters."""
    missing = [h for h in range(N // 2 + 1) if h not in per_nd]
    if missing:
        raise ValueError(f"body {body!r}: the annulus needs its reduction at every nodal "
                         f"diameter 0..{N // 2}; missing {missing}")
    first = per_nd[0]
    spec = first.damping_spec
    if spec is not None and len(spec.modal_ratios) > 1:
        raise ValueError(f"body {body!r}: a list of modal damping ratios means each ND's "
                         "lowest elastic modes in the sector, not the annulus' lowest: give "
                         "one ratio")
    for h, m in per_nd.items():
        if not np.array_equal(m.master_nodes, first.master_nodes):
            raise ValueError(f"body {body!r}: ND {h} has other master nodes than ND 0")
    regions = all(len(per_nd[h].region_dofs) for h in range(N // 2 + 1))
    return Annulus(N, {h: SectorND(per_nd[h].stiffness, per_nd[h].mass,
                                   per_nd[h].region if regions else None)
                       for h in range(N // 2 + 1)}, first.n_masters)


def _annulus_body(body: str, per_nd: Mapping[int, ReducedModel], a: Annulus,
                  node_map: np.ndarray) -> ReducedModel:
    """The tuned annulus as the full disk's body: every sector's masters, each ND's modes."""
    N, first = a.sectors, per_nd[0]
    turns = [rotation_z(s * a.phi) for s in range(N)]
    loads = {}
    if CENTRIFUGAL in first.loads:  # the same on every sector: ND 0's, its work N times
        loads[CENTRIFUGAL] = as_real(np.sqrt(N) * (a.to_nd(0).conj().T
                                                   @ first.loads[CENTRIFUGAL]),
                                     "centrifugal load")
    modes = np.concatenate([np.tile(per_nd[h].mode_frequencies, 1 if a.standing(h) else 2)
                            for h in range(N // 2 + 1)])
    return ReducedModel(
        body=body, method="annulus", stiffness=a.stiffness, mass=a.mass,
        master_nodes=np.concatenate([node_map[s, first.master_nodes] for s in range(N)]),
        master_coordinates=np.concatenate([first.master_coordinates @ R.T for R in turns]),
        n_modes=a.n - N * first.n_masters, mode_frequencies=modes,
        recovery_nodes=np.zeros(0, dtype=np.int64), recovery=np.zeros((0, 3, a.n)),
        patches={f"{p}#{s}": node_map[s, nodes] for p, nodes in first.patches.items()
                 for s in range(N)},
        damping_spec=first.damping_spec, loads=loads,
        key=_key([per_nd[h].key for h in sorted(per_nd)], None))


def _check_regions(body: str, per_nd: Mapping[int, ReducedModel], N: int,
                   mistuning: Mistuning) -> None:
    """ValueError unless every ND's reduction kept the same region's rows and the region's
    stiffness is square over them."""
    dofs = per_nd[0].region_dofs
    if not len(dofs):
        raise ValueError(f"mistuning: body {body!r} was reduced without a region's rows "
                         "(craig_bampton region_dofs): nothing to mistune")
    for h in range(N // 2 + 1):
        if not np.array_equal(per_nd[h].region_dofs, dofs):
            raise ValueError(f"mistuning: body {body!r}: ND {h} kept another region than "
                             "ND 0")
    K = _region_stiffness(per_nd[0], mistuning)
    if K is None:
        raise ValueError(f"mistuning: body {body!r}: no region stiffness given or kept by "
                         "its reduction")
    if K.shape != (len(dofs), len(dofs)):
        raise ValueError(f"mistuning.region_stiffness: shape {K.shape}, expected "
                         f"{(len(dofs), len(dofs))} (the region's DOFs)")


def _region_stiffness(model: ReducedModel, mistuning: Mistuning):
    """The region's stiffness: the mistuning's, else the one the reduction kept."""
    K = mistuning.region_stiffness
    return model.region_stiffness if K is None else K


def _turned_copy(m: ReducedModel, name: str, s: int, N: int, node_map: np.ndarray
                 ) -> ReducedModel:
    """A body without cyclic symmetry copied into sector s: its masters' coordinates
    turned by R(s phi) (global frame), its modes as they are."""
    R = rotation_z(2.0 * np.pi * s / N)
    T = np.eye(m.size)
    T[:m.n_masters, :m.n_masters] = np.kron(np.eye(len(m.master_nodes)), R)
    return replace(
        m, body=name, stiffness=T @ m.stiffness @ T.T, mass=T @ m.mass @ T.T,
        master_nodes=node_map[s, m.master_nodes],
        master_coordinates=m.master_coordinates @ R.T,
        recovery_nodes=node_map[s, m.recovery_nodes],
        recovery=np.einsum("ij,pjr,kr->pik", R, m.recovery, T) if len(m.recovery_nodes)
        else np.zeros((0, 3, m.size)),
        patches={f"{p}#{s}": node_map[s, nodes] for p, nodes in m.patches.items()},
        loads={k: T @ v for k, v in m.loads.items()},
        region_dofs=np.zeros(0, dtype=np.int64), region=np.zeros((0, m.size)),
        region_stiffness=None, key=_key([m.key, str(s)], None))


def _key(parts: Sequence[str], mistuning: Mistuning | None) -> str:
    h = hashlib.sha256("|".join(parts).encode())
    if mistuning is not None:
        h.update(np.asarray(mistuning.deviation, dtype=float).tobytes())
        if mistuning.region_stiffness is not None:  # (else the models' keys hold it)
            K = sp.csr_matrix(mistuning.region_stiffness)
            for part in (K.data, K.indices, K.indptr):
                h.update(np.ascontiguousarray(part).tobytes())
    return h.hexdigest()


@dataclass(frozen=True, eq=False)
class WholeDisk:
    """What ``join`` takes for the whole disk: the full disk's mesh, its reduced bodies,
    every sector's patch stiffness and the spec on every sector."""

    mesh: Mesh
    bodies: dict[str, dict[int, ReducedModel]]
    patch_stiffness: dict[str, Any]
    spec: AssemblySpec


def whole_disk(tuned: TunedDisk, full: Mesh, patch_stiffness: Mapping[str, Any],
               spec: AssemblySpec, mistuning: Mistuning | None) -> WholeDisk:
    """The whole disk of a sector case (``full``: ``geometry.full_disk(sector)``) with
    ``mistuning``'s pattern: each sector's patches with the sector's stiffness, the spec on
    every sector."""
    N = sector_count(tuned.sector)
    return WholeDisk(
        full, tuned.bodies_with(mistuning),
        {f"{p}#{s}": ps for p, ps in patch_stiffness.items() for s in range(N)},
        annulus_spec(spec, N, tuple(tuned.sector.cyclic)))


def blade_outputs(names: Sequence[str], sectors: int) -> list[str]:
    """Every blade's copy of each output, blade by blade within an output: "<name>#s"."""
    return [f"{n}#{s}" for n in names for s in range(sectors)]


def travelling_wave(sector: Any, disk: Any, x: np.ndarray, point: Any,
                    node_map: np.ndarray) -> np.ndarray:
    """The whole disk's unknowns of the cyclic sector's solution ``x`` at ``point``:
    the tuned disk's travelling wave. ``sector``, ``disk``: assembly.recovery.AssemblyModel
    of the sector and of the full disk; ``node_map`` (N, sector nodes): the full disk's node
    of each sector's node (``disk_node_map``). Sector s's DOFs are sector 0's turned by
    R(s phi) and delayed by the engine order's phase (order n: the complex amplitude times
    exp(i n EO s phi)). The tuned whole disk's solution, and a mistuned one's start (from
    a cold start the whole disk's sweep first ramps the excitation: minutes at 48 blades)."""
    N, eo = node_map.shape[0], sector.spec.engine_order
    hs, hd = sector.hb.harmonics, disk.hb.harmonics
    U = hs.to_complex(sector.hb.recover(x, point))  # every shared DOF of the sector
    # each node's first shared DOF (its x, y, z are consecutive)
    nodes, first = np.unique(sector.dof_nodes, return_index=True)
    disk_first = dict(zip(*np.unique(disk.dof_nodes, return_index=True)))
    triples = first[:, None] + np.arange(3)  # (nodes, 3) the sector's x, y, z DOFs
    X = {o: np.zeros(disk.hb.linear.n_dof, dtype=complex) for o in hd.orders}
    for s in range(N):
        to = np.array([disk_first[n] for n in node_map[s, nodes]])[:, None] + np.arange(3)
        turn = rotation_z(2.0 * np.pi * s / N)
        for o in hd.orders:
            X[o][to] = np.exp(1j * o * eo * s * 2.0 * np.pi / N) * (U[o][triples] @ turn.T)
    return hd.from_complex({o: v[disk.hb.dofs] for o, v in X.items()},
                           (disk.hb.dofs.size,)).ravel()
