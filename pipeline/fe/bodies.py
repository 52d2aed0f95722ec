"""The reduction stage of one body: what to reduce (:class:`BodySpec`: its masters, supports,
mode selection), its Craig-Bampton model per nodal diameter, kept in the HDF5 cache and
reused when the content key of its inputs matches."""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from microslip.geometry.boundaries import SurfaceContact
from microslip.geometry.pairing import paired_contact
from microslip.geometry.stored import written_whole

from . import cyclic, eigen, fem, linalg
from .craig_bampton import averaged_masters, craig_bampton
from .fem import Damping, IntArray, Material, MeshLike
from .reduced_model import (
    CENTRIFUGAL,
    CUTOFF,
    DEFAULT_MODES,
    ReducedModel,
    model_key,
    nodes_digest,
)


class ReductionError(RuntimeError):
    """A body's reduction failed for a numerical reason (the message names the body, the
    ND, what was tried and what to change)."""


@dataclass(frozen=True)
class BodySpec:
    """What to reduce for one body of a mesh.

    master_sets / recovery_sets / clamped_sets: node-set names (see the geometry models).
    supports: nodes held in some directions (``geometry.boundaries.Support``: a deck's, a case's).
    recovery_surface: also recover the vertices of the body's outer surface (what a
    picture of the deformed body draws).
    patches: contact-patch names whose nodes in this body are masters.
    n_modes, cutoff, f_max: fixed-interface mode selection (see ``craig_bampton``).
    order: element order.
    region: mesh elements of a region whose stiffness may deviate (a mistuned blade):
        every ND's model keeps its basis rows and stiffness (``ReducedModel.region``).
    """

    body: str
    material: Material
    master_sets: tuple[str, ...] = ()
    patches: tuple[str, ...] = ()
    recovery_sets: tuple[str, ...] = ()
    recovery_surface: bool = False
    clamped_sets: tuple[str, ...] = ()
    supports: tuple[Any, ...] = ()
    n_modes: int | str = DEFAULT_MODES
    cutoff: float = CUTOFF
    f_max: float | None = None
    order: int = 2
    damping: Damping | None = None
    region: tuple[int, ...] = ()


def patch_nodes(mesh: MeshLike, name: str, body: str) -> IntArray:
    """Nodes of contact patch ``name`` that belong to ``body`` (either side, grid order;
    both sides, a's then b's, when the body touches its neighbouring sector; sorted, for
    named surfaces)."""
    if name not in mesh.contacts:
        raise ValueError(f"contact patch {name!r} does not exist; available: "
                         f"{sorted(mesh.contacts)}")
    patch = mesh.contacts[name]
    if isinstance(patch, SurfaceContact):  # named surfaces: the nodes their pairs use
        if body not in (patch.body_a, patch.body_b):
            raise ValueError(f"contact {name!r} joins {patch.body_a!r} and "
                             f"{patch.body_b!r}, not body {body!r}")
        return paired_contact(mesh, name).nodes_of(body)
    if patch.body_a == body == patch.body_b:
        return np.concatenate([np.asarray(patch.nodes_a, dtype=np.int64).ravel(),
                               np.asarray(patch.nodes_b, dtype=np.int64).ravel()])
    if patch.body_a == body:
        return np.asarray(patch.nodes_a, dtype=np.int64).ravel()
    if patch.body_b == body:
        return np.asarray(patch.nodes_b, dtype=np.int64).ravel()
    raise ValueError(f"contact patch {name!r} joins {patch.body_a!r} and {patch.body_b!r}, "
                     f"not body {body!r}")


def spec_nodes(mesh: MeshLike, spec: BodySpec) -> tuple[IntArray, dict, IntArray, IntArray]:
    """(masters, patch name -> nodes, recovery nodes, clamped nodes) of a BodySpec; ValueError
    naming any node set or patch the mesh does not have, a body without masters, or masters
    without DOFs of their own (clamped, or on the cyclic face that follows the other)."""
    patches = {name: patch_nodes(mesh, name, spec.body) for name in spec.patches}
    masters = [*patches.values(), fem.node_sets_union(mesh, list(spec.master_sets))]
    master_nodes = np.unique(np.concatenate(masters)).astype(np.int64)
    recovery = fem.node_sets_union(mesh, list(spec.recovery_sets))
    if spec.recovery_surface:
        recovery = np.union1d(recovery, mesh.surface(spec.body))
    clamped = fem.node_sets_union(mesh, list(spec.clamped_sets))
    where = f"[reduction.bodies.{spec.body}] masters"
    if not len(master_nodes):
        raise ValueError(f"{where}: body {spec.body!r} has no master nodes (no contact of "
                         "its own, no node set named): name its interface nodes")
    cyc = mesh.cyclic.get(spec.body)
    follow = () if cyc is None else (cyc.right if cyc.slave_is_right else cyc.left)
    supported = (np.unique(np.concatenate([s.nodes for s in spec.supports]))
                 if spec.supports else np.empty(0, np.int64))
    for what, nodes in (("clamped", clamped), ("on the cyclic face that follows the other",
                                               follow), ("held by a support", supported)):
        bad = np.intersect1d(master_nodes, nodes)
        if len(bad):
            raise ValueError(f"{where}: {len(bad)} node(s) of body {spec.body!r} are {what} "
                             f"(first {bad[:5].tolist()}): masters need DOFs of their own")
    return master_nodes, patches, recovery, clamped


def model_path(mesh: MeshLike, spec: BodySpec, nodal_diameter: int | None,
               cache_dir: str | Path) -> Path:
    """Where ``reduce_body`` stores (and looks for) the model of ``spec`` at an ND (None for a
    body without cyclic symmetry): ``cache_dir/cb-<content hash>.h5``."""
    return _path(cache_dir, mesh, spec, *spec_nodes(mesh, spec), nodal_diameter)


def _path(cache_dir: str | Path, mesh: MeshLike, spec: BodySpec, master_nodes: IntArray,
          patches: dict, recovery: IntArray, clamped: IntArray,
          nodal_diameter: int | None) -> Path:
    key = model_key(mesh.content_hash, spec.body, spec.order, spec.material, clamped,
               nodal_diameter, "craig-bampton", master_nodes, spec.n_modes, recovery, patches,
               spec.cutoff, spec.f_max, _body_load_names(nodal_diameter), spec.supports)
    return Path(cache_dir) / f"cb-{_with_region(key, spec)[:32]}.h5"


def _with_region(key: str, spec: BodySpec) -> str:
    """A key with the spec's region in it (a key without one as it was)."""
    if not spec.region:
        return key
    return hashlib.sha256((key + nodes_digest(np.asarray(spec.region))).encode()).hexdigest()


def _body_load_names(nodal_diameter: int | None) -> tuple[str, ...]:
    """Names of the loads ``reduce_body`` projects at an ND (None: no cyclic symmetry): the
    centrifugal load is axisymmetric, so only ND 0 (or a non-cyclic body) carries it."""
    return (CENTRIFUGAL,) if nodal_diameter in (None, 0) else ()


def _eigen_failure(spec: BodySpec, h: int, n_free: int, backend: str | None, is_cyclic: bool,
                   err: Exception) -> str:
    """What a failed fixed-interface eigen-solve says: where, what was tried, what to change."""
    where = f"body {spec.body!r}" + (f" at ND {h}" if is_cyclic else "")
    solver = linalg.check_backend(backend, n_free)
    wanted = (f"every mode below {spec.cutoff:g} x the reference frequency" if spec.n_modes
              == "auto" else f"{spec.n_modes} modes")
    other = [b for b in linalg.available_backends() if b != solver]
    fewer = ("lower [reduction] cutoff or set " if spec.n_modes == "auto" else "set ")
    return (f"reduction of {where} ({n_free} free DOFs): the fixed-interface eigen-solve "
            f"(block shift-invert Lanczos, {wanted}, {solver} factorization) failed: {err}; "
            f"to change: {fewer}[reduction.bodies.{spec.body}] modes to fewer modes"
            + (f", or set [reduction] backend = \"{other[0]}\"" if other else ""))


def reduce_body(
    mesh: MeshLike,
    spec: BodySpec,
    nodal_diameters: Sequence[int] = (0,),
    cache_dir: str | Path | None = None,
    backend: str | None = None,
    report: Callable[[int, ReducedModel, Path | None, bool, float], None] | None = None,
) -> dict[int, ReducedModel]:
    """Craig-Bampton models of one body for each ND (a non-cyclic body: ND ignored, one model
    reused for all). Cached in ``cache_dir/<key>.h5``; the body is assembled once, and only on
    a cache miss. The model of ND 0 (and that of a non-cyclic body) carries the centrifugal
    load per unit Omega^2 in ``loads["centrifugal"]`` (see ``fem.centrifugal_load``); the
    other NDs have no load.

    report: called after each model as report(ND, model, file or None, from cache, seconds);
        a non-cyclic body reports once, as ND 0.
    """
    master_nodes, patches, recovery, clamped = spec_nodes(mesh, spec)
    boundary = mesh.cyclic.get(spec.body)
    if boundary is not None:
        for h in nodal_diameters:
            cyclic.check_nodal_diameter(h, boundary.sectors)
    nds = sorted(set(int(h) for h in nodal_diameters)) if boundary is not None else [0]
    out: dict[int, ReducedModel] = {}
    body_model = region_K = region_dofs = None
    for h in nds:
        t = time.perf_counter()
        path = None if cache_dir is None else _path(cache_dir, mesh, spec, master_nodes, patches,
                                                   recovery, clamped,
                                                   h if boundary is not None else None)
        model = _load(path, spec.damping)
        cached = model is not None
        if not cached:
            if body_model is None:
                body_model = fem.assemble(mesh, spec.body, spec.material, spec.order)
            if spec.region and region_K is None:
                region_K = fem.region_stiffness(mesh, spec.body, spec.material, spec.order,
                                                np.asarray(spec.region), body_model)
                region_dofs = np.unique(region_K.nonzero()[0])
            sector = cyclic.sector_model(body_model, clamped, boundary, h, spec.supports)
            names = _body_load_names(h if boundary is not None else None)
            loads = {CENTRIFUGAL: fem.centrifugal_load(body_model)} if names else None
            try:
                model = craig_bampton(sector, master_nodes, spec.n_modes, recovery, patches,
                                      spec.damping, backend, cutoff=spec.cutoff,
                                      f_max=spec.f_max, loads=loads,
                                      averaged=averaged_masters(mesh, master_nodes),
                                      region_dofs=() if region_K is None else region_dofs)
                if region_K is not None:
                    model = replace(model, key=_with_region(model.key, spec),
                                    region_stiffness=region_K[region_dofs][:, region_dofs])
            except eigen.EigenSolverError as err:
                raise ReductionError(_eigen_failure(spec, h, sector.n_free, backend,
                                                    boundary is not None, err)) from err
            if path is not None and not _kept(model, path):
                path = None  # (the cache could not be written: the run goes on)
        out[h] = model
        if report is not None:
            report(h, model, path, cached, time.perf_counter() - t)
    if boundary is None:
        return {int(h): out[0] for h in nodal_diameters}
    return out


def _load(path: Path | None, damping: Damping | None) -> ReducedModel | None:
    """The cached model at ``path`` with ``damping``, or None (absent, or unreadable: an older
    format or a damaged file, reduced again and replaced)."""
    if path is None or not path.exists():
        return None
    try:
        return ReducedModel.load(path).with_damping(damping)
    except (OSError, KeyError, ValueError):
        return None


def _kept(model: ReducedModel, path: Path) -> bool:
    """Whether ``model`` was kept at ``path`` (a cache that cannot take it, full or
    emptied meanwhile, only costs the next run the reduction)."""
    try:  # whole or not at all: a later run never takes a half-written model for a hit
        written_whole(path, model.save_into)
    except OSError:
        return False
    return True

