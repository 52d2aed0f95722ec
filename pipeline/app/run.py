"""Run a case end to end: every analysis, ``results.h5`` and the pictures.

Progress goes to a callable (the CLI prints it). Ctrl-C stops the run after
saving the branch computed so far; the results file is then marked partial.
"""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np
from threadpoolctl import ThreadpoolController

from microslip.case import (
    Case,
    GeometryTable,
    InputError,
    contact_elements,
    curve_variants,
    harmonics,
    lumped_model,
    operating_point,
    settings,
    task_seconds,
)
from microslip.case.geometry_table import contents_lines
from microslip.case.specs import (
    Analysis,
    Dti,
    Frf,
    Loops,
    Modes,
    Peak,
    TimeIntegration,
    Transient,
)
from microslip.case.units import case_unit_lines
from microslip.draw import pictures
from microslip.draw.files import written
from microslip.draw.maps import EDGES
from microslip.fourier import Harmonics
from microslip.geometry.mesh import AveragedContact, SurfaceContact
from microslip.geometry.pairing import paired_contact
from microslip.laws import warm_up
from microslip.results import schema
from microslip.results.writer import (
    ATTRS,
    ResultsWriter,
    is_disk_full,
    sampling_warning,
    set_attrs,
)
from microslip.solve.bifurcation import find_bifurcations
from microslip.solve.response import (
    Response,
    peak_curve,
    response_measure,
    stability_at,
    sweep,
)
from microslip.solve.stability import hill_stability, undefined

from .cache import SharedCache, built_mesh
from .folder import FolderLock, NoSpace, free_bytes, size_text
from .limits import LEVEL_POINTS, linear_limits, peak_levels
from .models import AssemblyModels, LumpedModels
from .progress import time_left
from .solutions import map_groups, map_solutions, response_at, sampling_change
from .store import CurveStore, draw_once
from .tasks import Distributed, Outcome, Serial, Task
from .uncertainty import run_uncertainty

if TYPE_CHECKING:
    from microslip.assembly.recovery import PatchState

    from .structure import StructureResult

Progress = Callable[[str], None]


@dataclass(frozen=True)
class Run:
    """What every analysis of a run shares: the results writer, the output folder, where
    progress goes, the models of the case (built once) and the curves kept between runs."""

    writer: ResultsWriter
    out: Path
    progress: Progress
    models: LumpedModels | AssemblyModels
    store: CurveStore
    executor: Serial | Distributed
    structure: tuple[Any, Any] | None = None  # (mesh, StructureResult) of a reduced case


class StageFailed(RuntimeError):
    """A stage before the analyses failed for a numerical reason (the message says where
    and what to change): the run ends ``failed``, exit 1."""


def run_case(case: Case, out_dir: str | Path, progress: Progress = print,
             cache: bool = True, executor: Serial | Distributed | None = None,
             shared: SharedCache | None = None) -> Path:
    """Compute every analysis of ``case`` into ``out_dir``; returns results.h5.

    cache: reuse the curves kept in ``out_dir/cache`` whose inputs are unchanged (and keep
    the new ones); False computes everything afresh (and keeps nothing). executor: where
    the independent curves run (``tasks``; default: in this process, one after another);
    the caller closes it. shared: where meshes and reduced models are kept for every run
    (``cache``; default: the environment's, ``SharedCache.from_environment``)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    free = free_bytes(out)
    with FolderLock(out) as lock:  # FolderBusy: another run writes there
        try:
            if shared is None and "geometry" in case.data:
                shared = SharedCache.from_environment()
            return _run_case(case, out, progress, cache, executor, lock, shared)
        except OSError as err:
            if not is_disk_full(err):
                raise
            raise NoSpace(disk_full_text(out, free)) from None


def disk_full_text(out: Path, free: int) -> str:
    """The one line of a run whose disk filled: where, what was free, what was kept."""
    path = out / "results.h5"
    kept = ""
    if (out / "results.h5.tmp").is_file():  # the file could not be closed
        kept = "; what finished is in results.h5.tmp, which could not be closed (show reads it)"
    elif path.is_file():
        with h5py.File(path, "r") as f:
            curves = sum(1 for g in f.values() if isinstance(g, h5py.Group)
                         for c in g.values() if isinstance(c, h5py.Group)
                         and c.attrs.get("status") in ("complete", "stopped"))
        kept = f"; {path} keeps the {curves} curves that finished (partial)"
    return (f"{out}: no space left on its device; {size_text(free)} were free when the run "
            f"started and it needs more: free space there, or give --out on another "
            f"disk{kept}")


@contextlib.contextmanager
def numba_threads(threads: int):
    """The contact kernels' numba threads at most ``threads`` for the block (numba's own
    default is every core)."""
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    try:
        yield
    finally:
        numba.set_num_threads(before)


def _run_case(case: Case, out: Path, progress: Progress, cache: bool,
              executor: Serial | Distributed | None, lock: FolderLock,
              shared: SharedCache | None) -> Path:
    """run_case in the folder it holds."""
    store = CurveStore(out / "cache" / "curves" if cache else None)
    executor = executor or Serial()
    # every stage, the reduction's factorizations included, with the run's BLAS threads
    # (``--threads``): the same numbers here as on any worker
    with ThreadpoolController().limit(limits=executor.threads, user_api="blas"), \
            numba_threads(executor.threads), \
            ResultsWriter(out / "results.h5", title=case.title, source=case.source,
                          case_hash=case.content_hash, case=case.data,
                          on_disk_full=lock.release_reserve) as writer:
        stopped = ""
        models: LumpedModels | AssemblyModels = LumpedModels()
        structure = None
        if "geometry" in case.data:
            t = time.perf_counter()
            m = mesh_geometry(case.geometry_table, out, progress, pictures=False,
                              cache=shared)
            say_units(case.data, progress)
            write_mesh(writer, m, time.perf_counter() - t)
            draw_previews(writer.file, m.content_hash, out, progress)
            if "reduction" in case.data:
                try:
                    result = write_structure(writer, m, case, out, progress, shared)
                except StageFailed as err:  # numerical: said, kept in the file, exit 1
                    progress(f"[reduction] failed: {err}")
                    return writer.close("failed", str(err))
                structure = (m, result)
                if "assembly" in case.data:
                    models = AssemblyModels(m, result)
        unfinished: list[tuple[str, str, str]] = []  # (name, status, why) not complete
        run = Run(writer, out, progress, models, store, executor, structure)
        for spec in case.analysis_specs:
            name = spec.name
            t = time.perf_counter()
            group = writer.analysis(name, spec.record())
            progress(f"[{name}] {spec.type} ...")
            if spec.type in ("frf", "peak", "uncertainty", "loops") and (case.contacts_enabled()
                                                          or "assembly" in case.data):
                warm_up(progress)  # says so when a first run compiles the contact kernels
            status, message = RUNNERS[spec.type](case, spec, group, run)
            group.attrs["status"] = status
            group.attrs["message"] = message
            group.attrs["elapsed_s"] = time.perf_counter() - t
            writer.flush()
            progress(f"[{name}] {status} in {time.perf_counter() - t:.2f} s {message}".rstrip())
            if status == "interrupted":
                stopped = f"interrupted by the user in analysis {name}"
                break
            if status != "complete":
                unfinished.append((name, status, message))
        if stopped:
            return writer.close("partial", stopped)
        if unfinished:  # a stopped or failed curve is not a complete run
            failed = [u for u in unfinished if u[1] == "failed"]
            status = "failed" if len(failed) == len(case.analyses) else "partial"
            return writer.close(status, "; ".join(f"analysis {n} {s}: {m}".rstrip(": ")
                                             for n, s, m in unfinished))
    return out / "results.h5"


def mesh_geometry(table: GeometryTable, out: Path, progress: Progress = print,
                  pictures: bool = True, cache: SharedCache | None = None):
    """Build (or read) the [geometry] of a case, a parametric model's mesh kept in the
    shared ``cache``; write mesh.msh, mesh.vtu and (``pictures``) the previews (``microslip
    mesh``: no results file; a run draws them from results.h5)."""
    t = time.perf_counter()
    try:
        m, kept = built_mesh(table, cache)
    except ValueError as err:  # a declared contact on a model known only once meshed
        raise InputError(str(err)) from None
    elapsed = time.perf_counter() - t
    with written(out / "mesh.msh") as tmp:  # whole or not at all (a full disk)
        m.write_msh(tmp)
    with written(out / "mesh.vtu") as tmp:
        m.write(tmp)
    source = (f"{table.file} ({table.units})" if table.imported else m.model)
    where = f" from the shared cache ({kept.parent})" if kept else ""
    progress(f"[geometry] {source}: {m.points.shape[0]} nodes, {m.element_summary()}, "
             f"bodies {sorted(m.bodies)}, cyclic {sorted(m.cyclic)}, contacts "
             f"{sorted(m.contacts)} in {elapsed:.2f} s{where}; hash {m.content_hash[:12]}")
    for name, c in sorted(m.contacts.items()):
        dropped = (paired_contact(m, name).dropped
                   if isinstance(c, SurfaceContact | AveragedContact) else (0,))
        if dropped[0]:
            progress(f"[geometry] note: contact {name}: {dropped[0]} node(s) of {c.set_a} lie "
                     f"beyond {c.set_b} (up to {dropped[1]:.3g} m) and touch nothing (trim the "
                     "set, or raise the contact's tolerance if they should touch)")
    report = table.read().report if table.imported else None
    if table.imported:
        for line in contents_lines(m):
            progress(f"[geometry] {line}")
    if report is not None and report.skipped:
        progress("[geometry] note: not solids, so not part of the model (their nodes are node "
                 "sets): " + ", ".join(f"{n} {t}" for t, n in sorted(report.skipped.items())))
    if report is not None and report.dropped_sets:
        progress("[geometry] note: node sets of mid-side nodes only, so empty on the corner "
                 "mesh (name corner nodes instead): " + ", ".join(report.dropped_sets))
    if report is not None and report.curved_edges:
        progress(f"[geometry] {report.curved_edges} curved edges kept as the file has them "
                 f"(mid-edge nodes up to {100 * report.midnode_offset:.2g} % of an edge off "
                 "straight)")
    if pictures:
        from microslip.draw.previews import MeshView

        draw_previews(MeshView.from_mesh(m), m.content_hash, out, progress)
    return m


def say_units(data: dict, progress: Progress) -> None:
    """The unit an imported mesh was read in when the case gives none, and a warning per
    body implausible in its units (``case.units``)."""
    notes, warnings = case_unit_lines(data)
    for line in notes:
        progress(f"[geometry] note: {line}")
    for line in warnings:
        progress(f"warning: [geometry] {line}")


def draw_previews(source, content_hash: str, out: Path, progress: Progress = print) -> None:
    """The mesh previews of ``source`` (a results file being written, or a
    ``previews.MeshView``), unless those of the same mesh (``content_hash``) are there."""
    from microslip.draw.previews import MeshView, preview_names, render_previews

    view = source if isinstance(source, MeshView) else MeshView.from_results(source)
    stamp = out / "cache" / "previews.hash"  # the mesh the previews show
    names = [out / name for name in preview_names(view)]
    if stamp.is_file() and stamp.read_text() == content_hash and all(
            p.is_file() for p in names):
        progress(f"[geometry] previews unchanged ({', '.join(p.name for p in names)})")
        return
    for path in render_previews(view, out):
        progress(f"[geometry] wrote {path}")
    stamp.parent.mkdir(parents=True, exist_ok=True)
    stamp.write_text(content_hash)


def write_mesh(writer: ResultsWriter, mesh, elapsed: float) -> None:
    """/geometry (attrs: the model, its sizes and names; /geometry/cyclic/<body>: the cyclic
    faces' node positions), /surfaces (every body's outer surface) and /contact_grids:
    what the previews, maps and shapes are drawn on."""
    from microslip.draw.previews import MeshView

    view = MeshView.from_mesh(mesh)  # each body's surface found once
    writer.write_group(writer.file, schema.GEOMETRY, {schema.CYCLIC: view.cyclic_datasets()}, {
        "model": mesh.model, "content_hash": mesh.content_hash, "nodes": mesh.points.shape[0],
        "elements": mesh.element_summary(), "bodies": sorted(mesh.bodies),
        "contacts": sorted(mesh.contacts), "parameters": mesh.parameters,
        "status": "complete", "elapsed_s": elapsed, "type": "geometry"})
    write_contact_grids(writer, mesh)
    sectors = min((c.sectors for c in view.cyclic), default=0)
    writer.write_group(writer.file, schema.SURFACES, view.surface_datasets(),
                       {"sectors": sectors})


def write_contact_grids(writer: ResultsWriter, mesh) -> None:
    """/contact_grids/<patch>: each patch's node grid, frame and map orientation
    (maps.PatchGrid), what the maps are drawn on."""
    from microslip.draw.maps import PatchGrid

    for name in sorted(mesh.contacts):
        grid = PatchGrid.from_mesh(mesh, name)
        patch = mesh.contacts[name]
        writer.write_group(writer.file.require_group(schema.CONTACT_GRIDS), name,
                           grid.datasets() | {"points_b": mesh.points[grid.nodes_b]},
                           {"body_a": grid.body_a, "body_b": grid.body_b,
                            "high_edge": grid.high_edge,
                            "high_edge_name": EDGES[grid.high_edge] if grid.structured
                            else "", "b_sector_offset": int(patch.b_sector_offset)})


def write_structure(writer: ResultsWriter, mesh, case: Case, out: Path,
                    progress: Progress = print, cache: SharedCache | None = None
                    ) -> StructureResult:
    """The [reduction] stage: reduced models in the shared ``cache`` (reused when
    unchanged, by any run; None: kept nowhere) and their summary in results.h5
    /reduction/<body>/nd<h> (frequencies of the reduced model with free masters,
    fixed-interface mode frequencies, master nodes; attrs: model file name in the cache,
    sizes) and /reduction/contact_stiffness/<patch> (kn, kt per node pair [N/m])."""
    from microslip.fe.bodies import ReductionError

    from .structure import reduce_structure  # imports the FE stages only when needed

    t = time.perf_counter()
    orders = harmonics(case).orders if "harmonics" in case.data else None
    shapes = case.draws_shapes
    try:
        result = reduce_structure(mesh, case.reduction_table,
                                  cache.models if cache is not None else None, orders,
                                  progress, surfaces=shapes)
    except ReductionError as err:
        raise StageFailed(str(err)) from err
    if cache is not None:  # the least recently used beyond the bound go, never these
        cache.used(result.files.values())
        cache.prune(keep=result.files.values())
    datasets: dict = {body: {schema.nodal_diameter(h): {
        "frequencies_hz": result.frequencies[body, h], "mode_frequencies_hz": m.mode_frequencies,
        "master_nodes": m.master_nodes} for h, m in models.items()}
        for body, models in result.models.items()}
    datasets[schema.CONTACT_STIFFNESS] = {
        name: {"normal_n_per_m": s.normal, "tangential_n_per_m": s.tangential}
        for name, s in result.patch_stiffness.items()}
    writer.write_group(writer.file, schema.REDUCTION, datasets, {
        "nodal_diameters": list(result.nodal_diameters), "status": "complete",
        "f_max_hz": -1.0 if result.f_max is None else result.f_max,
        "cached": [f"{b} ND {h}" for b, h in result.cached], "type": "reduction",
        "elapsed_s": time.perf_counter() - t})
    for body, models in result.models.items():
        for h, m in models.items():
            attrs = writer.file[schema.REDUCTION][body][schema.nodal_diameter(h)].attrs
            attrs["n_modes"], attrs["n_master_dofs"] = m.n_modes, m.n_masters
            path = result.files.get((body, h))
            attrs["file"] = "" if path is None else path.name
    where = f" ({cache.models})" if cache is not None else ""
    progress(f"[reduction] {len(result.cached)} of {len(result.seconds)} models from the "
             f"shared cache{where}; stage {time.perf_counter() - t:.1f} s")
    return result


def _outputs(case: Case, names: tuple[str, ...] | None, models=None
             ) -> tuple[list[str], object]:
    """(output names, their selection: DOF indices or rows of the shared DOFs); ``names``
    None: every output of the case."""
    models = models or LumpedModels()
    names = list(names) if names is not None else models.names(case)
    return names, models.selection(case, names)


def ticker(progress: Progress, prefix: str, start: float, stop: float,
            clock: Callable[[], float] = time.perf_counter) -> Callable[[int, float, int], None]:
    """Continuation ticks, at most one line a second: the point, the share of the parameter
    range covered (the farthest reached: arclength turns back at folds) and the time left."""
    t0 = clock()
    last = [-np.inf]
    covered = [0.0]

    def tick(n: int, value: float, iterations: int) -> None:
        covered[0] = max(covered[0], min(max((value - start) / (stop - start), 0.0), 1.0))
        now = clock()
        if now - last[0] > 1.0:
            last[0] = now
            left = time_left(now - t0, covered[0])
            progress(f"{prefix} point {n}, value {value:.6g} ({covered[0]:.0%} of the range"
                     f"{', ' + left if left else ''}), {iterations} Newton iterations")

    return tick


def _contact_data(r: Response, per_point: list) -> dict:
    """Per contact and point: state, dissipation, slip fraction, static forces (and the
    names of their columns per contact point)."""
    out = {}
    for ci, c in enumerate(r.model.contacts):
        rows = [contacts[ci] for contacts in per_point]
        el = c.elements
        if el.coupled and r.model.harmonics.has_static:  # (no point: a curve without start)
            static = np.array([x.forces[:, :, 0].ravel() for x in rows],
                              dtype=float).reshape(len(rows), el.size * el.n_components)
        elif el.variable_normal:
            # uncoupled: the static forces assumed a priori, N0 (T0 not modelled: NaN)
            n0 = np.array([el.n0 * r.point(i).preload for i in range(len(r))],
                          dtype=float).reshape(len(r), el.size)
            static = np.concatenate([np.full((len(r), el.size * el.dim), np.nan), n0], axis=1)
        else:
            static = np.zeros((len(r), 0))
        columns = [f"T0_{j + 1}" if el.dim > 1 else "T0" for j in range(el.dim)]
        columns += ["N0"] if el.variable_normal else []
        out[c.name] = {
            "state": np.array([x.state[0] for x in rows], dtype=np.int8),
            "node_state": np.array([x.state for x in rows], dtype=np.int8),
            "dissipation": np.array([x.dissipation.sum() for x in rows]),
            "slip_fraction": np.array([x.slip_fraction.mean() for x in rows]),
            "static_force": static,
            "columns": np.array(columns if static.shape[1] else [], dtype="S"),
            "undersampled": np.array([x.undersampled.sum() for x in rows]),
        }
    return out


def _sampling_changes(r: Response, contacts: dict, rows, measure: str, status: str
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(n,) relative response change and (n,) parameter shift of each point whose stick
    arcs fall within two samples, when the period is sampled twice as finely (first order,
    :func:`sampling_change`); NaN at the other points (and all of an interrupted curve)."""
    change, shift = np.full(len(r), np.nan), np.full(len(r), np.nan)
    if status == "interrupted" or not contacts:
        return change, shift
    coarse = np.any([c["undersampled"] > 0 for c in contacts.values()], axis=0)
    for i in np.flatnonzero(coarse):
        change[i], shift[i] = sampling_change(r, int(i), rows, measure)
    return change, shift


def _patch_data(states: list[dict[str, PatchState]]) -> dict:
    """Per patch and point (n points, P node pairs): state (n, P), static forces
    [T0_1, T0_2, N0] (n, P, 3) [N], the share of slipping node pairs (n,)."""
    if not states:
        return {}
    return {p: {"state": np.array([s[p].state for s in states], dtype=np.int8),
                "static": np.array([s[p].static for s in states]),
                "slip_share": np.array([s[p].slip_share for s in states])}
            for p in states[0]}


def frf_key(store: CurveStore, case: Case, spec: Frf, method: str) -> str:
    """The store key of one FRF branch; deformed shapes at its map points are part of what
    it computes."""
    return store.key(case.data, spec.table(), method=method, curve="frf", shapes=spec.shapes)


def run_frf(case: Case, spec: Frf, group: h5py.Group, run: Run) -> tuple[str, str]:
    """Every curve of an frf (a family value and a method each: a task each), the linear
    limits of an assembly case's frequency sweep, the pictures; (status, message) of the
    worst curve."""
    name, store, progress = spec.name, run.store, run.progress
    methods = spec.method
    statuses: dict[int, tuple[str, str]] = {}
    keys: list[str] = []
    whiches: list[str] = []
    tasks: list[Task] = []
    targets: list[tuple[int, str, str]] = []
    hits = store.hits
    each = task_seconds(case.data, spec)
    j = 0
    for variant, label, value in curve_variants(case, spec):
        for method in methods:
            tag = ", ".join(x for x in (label, method if len(methods) > 1 else "") if x)
            which = f"[{name}] curve {j + 1} {tag}".rstrip()
            whiches.append(which)
            key = frf_key(store, variant, spec, method)
            keys.append(key)
            curve = schema.curve(j)
            kept = _cached_curve(store, key, group, curve, f"{which}: {{}} points", progress,
                                 frf_identity(spec, tag, value))
            if kept:
                statuses[j] = kept
            else:
                tasks.append(Task(frf_task, (variant, spec, method, tag, value, which), which,
                                  each))
                targets.append((j, key, curve))
            j += 1
    statuses |= _computed(run, group, tasks, targets, f"[{name}] ")
    for k in sorted(statuses):
        written = k >= 0 and schema.curve(k) in group  # a failed task has no curve
        coarse = sampling_warning(group[schema.curve(k)]) if written else ""
        if coarse:
            progress(f"warning: {whiches[k]}: {coarse}")
    done = [statuses[k] for k in sorted(statuses)]
    if isinstance(run.models, AssemblyModels) and spec.parameter == "frequency" and done \
            and not _interrupted(done):
        linear_limits(run.models, case, spec, run.writer, group, store, progress)
    every = len(keys) + sum(schema.is_linear(k) for k in group)
    _draw(pictures.frf, group, spec, run, keys, store.hits - hits == every)
    return _worst(done)


def _interrupted(statuses: list[tuple[str, str]]) -> bool:
    return any(s == "interrupted" for s, _ in statuses)


def _computed(run: Run, group: h5py.Group, tasks: list[Task],
              targets: list[tuple[int, str, str]], what: str) -> dict[int, tuple[str, str]]:
    """Run the curves' ``tasks`` (``targets``: each one's (index, store key, group name)),
    writing each into ``group`` as it finishes and keeping the finished ones (complete, or
    stopped for a reason a re-run would meet again) in the store; {index: (status,
    message)}. An interrupt (an interrupted curve, or Ctrl-C while a cluster works) ends it:
    then index -1 holds the interruption."""
    out: dict[int, tuple[str, str]] = {}
    try:
        for i, outcome in run.executor.run(tasks, run.models, run.progress, what):
            j, key, curve = targets[i]
            if outcome.data:  # a task that failed on a worker brought nothing
                run.writer.write_group(group, curve, outcome.data, outcome.attrs)
                run.writer.flush()
            out[j] = (outcome.status, outcome.message)
            if outcome.status in ("complete", "stopped"):
                run.store.save(key, group[curve])
            for line in outcome.lines:
                run.progress(line)
            if outcome.status == "interrupted":
                break
    except KeyboardInterrupt:  # the cluster's outstanding tasks are cancelled
        out[-1] = ("interrupted", "interrupted by the user")
    return out


def _draw(draw, group: h5py.Group, spec: Analysis, run: Run, keys: list[str] = (),
          cached: bool = False) -> None:
    draw_once(draw, group, spec, run.out, run.progress, keys, cached)


def _cached_curve(store: CurveStore, key: str, group, curve: str, what: str,
                  progress: Progress, identity: dict) -> tuple[str, str] | None:
    """(status, message) of the curve ``group[curve]`` copied from the store, saying so
    (``what`` formats its number of points); None when the store does not have it.

    The store is keyed by what a curve computes, so another analysis (or another family
    member) may have computed it: its ``identity`` attributes (label, family key and value)
    are this analysis' own, set over the stored ones."""
    if not store.load(key, group, curve):
        return None
    g = group[curve]
    set_attrs(g, identity)
    status, message = str(g.attrs["status"]), str(g.attrs["message"])
    progress(f"{what.format(g['parameter'].shape[0])}, {status}, from the cache "
             f"(computed in {g.attrs['elapsed_s']:.1f} s) {message}".rstrip())
    return status, message


def frf_identity(spec: Frf, tag: str, value) -> dict:
    """The attributes of an FRF curve that say which analysis and member it is (not what it
    computes): its label, family key and value."""
    return {"label": tag, "family_key": spec.family.key if spec.family else "",
            "family_value": value if value is not None else ""}


def peak_identity(spec: Peak, label: str, value) -> dict:
    """The attributes of a peak curve that say which analysis and member it is."""
    return {"label": label or f"peak of {spec.output}", "family_value": value or ""}


def frf_task(models: LumpedModels | AssemblyModels, c: Case, spec: Frf, method: str, tag: str,
             value, which: str, *, progress: Progress, live: bool = True) -> Outcome:
    """One FRF branch (and its map points) of the case variant ``c``: a task (``tasks``);
    ``live`` False leaves out the per-point ticks."""
    par, measure, wanted = spec.parameter, spec.measure, list(spec.maps)
    names, idx = _outputs(c, spec.outputs, models)
    start, stop = spec.start, spec.stop
    if method == "natural-down":
        start, stop = stop, start
    hb = models.model(c)
    t = time.perf_counter()
    base = operating_point(c, spec.omega).set(par, start)
    r = sweep(hb, par, start, stop, base,
              method="natural" if method.startswith("natural") else method,
              settings=settings(c),
              progress=ticker(progress, which, start, stop) if live else None)
    elapsed = time.perf_counter() - t
    b = r.branch
    if not len(r) and b.status == "stopped":  # no start point: nothing of the curve
        b.status = "failed"
    coef = r.coefficients(idx) if len(r) else np.zeros((0, len(idx), hb.harmonics.n_coeffs))
    amp = hb.harmonics.peak(coef) if len(r) else np.zeros((0, len(idx)))
    shown = response_measure(hb.harmonics, coef, measure) if len(r) else amp
    if spec.normalise and len(r):  # per unit of the excitation multiplier
        shown = shown / np.array([r.point(i).excitation for i in range(len(r))])[:, None]
    per_point = [r.contacts(i) for i in range(len(r))]  # every contact, once per point
    contacts = _contact_data(r, per_point)
    try:
        stability = _stability_data(r, spec, settings(c), idx, progress, which)
    except KeyboardInterrupt:  # the branch is kept, without its stability
        stability = {}
        b.message = "; ".join(m for m in (b.message, "interrupted by the user during the "
                                          "stability analysis") if m)
        b.status = "interrupted"
    change, shift = _sampling_changes(r, contacts, idx, measure, b.status)
    jumps = np.array(b.jumps, dtype=np.int64).reshape(-1, 2)
    data = {
        "parameter": b.values, "omega": r.omega if len(r) else np.zeros(0),
        "coefficients": coef, "amplitude": amp, "response": shown,
        "residual": b.residuals, "iterations": b.iterations,
        "turning_points": np.array(b.turning_points, dtype=np.int64),
        # natural sweeps: (from, to) points of each jump at a fold and their parameter values
        "jumps": jumps, "jump_parameter": b.values[jumps],
        "unknowns": b.x, "unknown_dofs": hb.dofs,
        schema.CONTACTS: contacts, "sampling_change": change, "sampling_shift": shift,
        **stability,
    }
    if isinstance(models, AssemblyModels):  # each unknown's mesh node and x/y/z
        from microslip.assembly.recovery import patch_states

        cm = models.assembly(c)
        data["unknown_nodes"] = cm.dof_nodes[hb.dofs]
        data["unknown_directions"] = hb.dofs % 3
        names_c = [ct.name for ct in hb.contacts]
        data[schema.PATCHES] = _patch_data([patch_states(names_c, cm.points, p)
                                       for p in per_point])
        if wanted and b.status != "interrupted":
            sols = map_solutions(r, wanted, idx, measure, settings(c))
            data[schema.MAPS] = map_groups(cm, r, sols, idx, measure, spec.normalise,
                                           models.surfaces() if spec.shapes else None)
            for m in data[schema.MAPS].values():
                progress(f"{which}: map point, {m[ATTRS]['what']} at {par} "
                         f"{m[ATTRS]['parameter']:.6g}: response {m['response'][0]:.4g} m")
            missing = [x for x in wanted if x != "peak" and not any(s[1] == x for s in sols)]
            if missing:
                progress(f"warning: {which}: no solution found at {par} = "
                         f"{', '.join(f'{x:g}' for x in missing)} for its maps")
    attrs = frf_identity(spec, tag, value) | {
        "method": method, "measure": measure, "status": b.status, "message": b.message,
        "turning_points": b.turning_points, "elapsed_s": elapsed, "outputs": names,
        "harmonic_orders": list(hb.harmonics.orders), "samples": hb.harmonics.n_samples,
        "mass_multiplier": base.mass_multiplier, "excitation": base.excitation,
        "normalised": spec.normalise}
    done = f"{which}: {len(r)} points, {b.status} ({elapsed:.2f} s) {b.message}".rstrip()
    return Outcome(data, attrs, b.status, b.message, (done,))


def _stability_data(r: Response, spec: Frf, solver, rows, progress: Progress, which: str
                    ) -> dict:
    """Hill's stability at every point of a branch and its bifurcations, as results.h5
    datasets (none for a linear model or with ``stability = false``), each bifurcation's
    response measured like the curve's (``rows``: the outputs); the terminal lists them."""
    if not (spec.stability and len(r) and r.model.n_unknowns):
        return {}
    t = time.perf_counter()
    hb, par = r.model, r.parameter
    why = undefined(hb)
    if why:
        progress(f"{which}: no stability: {why}")
        return {}
    points = [hill_stability(hb, x, r.point(i)) for i, x in enumerate(r.branch.x)]
    t_points = time.perf_counter() - t
    found = find_bifurcations(r, points, solver)
    floquet = _floquet(points)
    stable = np.array([s.stable for s in points])
    shown = np.zeros((len(found), len(rows)))
    for k, f in enumerate(found):
        p = r.base.set(par, f.parameter)
        shown[k] = response_at(hb, f.x, p, rows, spec.measure) / (
            p.excitation if spec.normalise else 1.0)
    progress(f"{which}: stability of {len(r)} points ({t_points:.2f} s): "
             f"{np.count_nonzero(~stable)} unstable, {len(found)} bifurcation"
             f"{'s' if len(found) != 1 else ''}"
             + (f" (located in {time.perf_counter() - t - t_points:.2f} s)" if found else "")
             + _incomplete(points))
    for f in found:
        progress(f"{which}:   {f.kind} at {par} {f.parameter:.8g} (after point {f.index}), "
                 f"exponent {f.exponent.real:.3g}{f.exponent.imag:+.3g}i 1/s"
                 + ("" if f.located else ", not located"))
    return {"stable": stable, "floquet": floquet, schema.BIFURCATIONS: {
        "kind": np.array([f.kind for f in found], dtype="S"),
        "index": np.array([f.index for f in found], dtype=np.int64),
        "parameter": np.array([f.parameter for f in found]),
        "omega": np.array([f.omega for f in found]),
        "response": shown,
        "exponent": np.array([f.exponent for f in found], dtype=complex),
        "located": np.array([f.located for f in found], dtype=bool)}}


def _incomplete(points: list) -> str:
    """A note of the points whose exponents near zero ARPACK did not all find (their
    verdict rests on those it found), or ""."""
    k = sum(1 for s in points if s is not None and not s.complete)
    return f"; {k} points' exponents incomplete (ARPACK)" if k else ""


def _floquet(points: list) -> np.ndarray:
    """(n, schema.FLOQUET) the leading exponents of each point's Stability (NaN: fewer, or
    no stability there)."""
    out = np.full((len(points), schema.FLOQUET), np.nan + 0j)
    for i, s in enumerate(points):
        if s is not None:
            k = min(s.exponents.size, schema.FLOQUET)
            out[i, :k] = s.exponents[:k]
    return out


def _attr_list(values: list[str]) -> str:
    return json.dumps(list(values))


def _normal(hb, contact: str) -> bool:
    return next(c for c in hb.contacts if c.name == contact).elements.variable_normal


def _peak_ticker(progress: Progress, name: str, label: str, par: str):
    def tick(i, value, omega, amplitude, how):
        progress(f"[{name}] {label} {par} = {value:.6g}: peak {amplitude:.6g} at w = "
                 f"{omega:.6g} rad/s ({how})")
    return tick


def run_peak(case: Case, spec: Peak, group: h5py.Group, run: Run) -> tuple[str, str]:
    """Every peak curve (one per family value: a task each, or with ``tracking = "sweep"``
    a task per value) and, with ``levels`` on an assembly case, the free and fully stuck
    peak levels; the picture; (status, message) of the worst curve."""
    name, store, models = spec.name, run.store, run.models
    statuses: list[tuple[str, str]] = []
    keys: list[str] = []
    hits = store.hits
    n = len(spec.values()) if spec.tracking == "sweep" else 1  # tasks per curve
    each = task_seconds(case.data, spec)
    tasks: list[Task] = []
    curves: list[tuple[str, str, str, object]] = []  # (key, group name, label, value)
    for j, (variant, label, value) in enumerate(curve_variants(case, spec)):
        key = store.key(variant.data, spec.table(), curve="peak")
        keys.append(key)
        kept = _cached_curve(store, key, group, schema.curve(j),
                             f"[{name}] {label or 'curve'}: {{}} values", run.progress,
                             peak_identity(spec, label, value))
        if kept:
            statuses.append(kept)
            continue
        curves.append((key, schema.curve(j), label, value))
        tasks += [Task(peak_task, (variant, spec, label, i if n > 1 else None),
                       f"[{name}] {label or 'curve'}", each) for i in range(n)]
    rows: dict[int, Outcome] = {}
    try:
        for i, outcome in run.executor.run(tasks, models, run.progress, f"[{name}] "):
            rows[i] = outcome
            for line in outcome.lines:
                run.progress(line)
            if outcome.status == "interrupted":
                break
    except KeyboardInterrupt:
        statuses.append(("interrupted", "interrupted by the user"))
    for k, (key, curve, label, value) in enumerate(curves):
        status, message = _write_peak_curve(group, curve, label, value, spec,
                                            [rows.get(k * n + i) for i in range(n)], run)
        statuses.append((status, message))
        if status in ("complete", "stopped"):
            store.save(key, group[curve])
    if spec.levels and isinstance(models, AssemblyModels) and not _interrupted(statuses):
        variant = case.with_values(spec.set)
        key = store.key(variant.data, spec.table(), curve="levels", points=LEVEL_POINTS)
        if not (store.load(key + "f", group, schema.LEVEL_FREE)
                and store.load(key + "s", group, schema.LEVEL_STUCK)):
            for k in (schema.LEVEL_FREE, schema.LEVEL_STUCK):
                if k in group:
                    del group[k]
            peak_levels(models.assembly(variant), operating_point(variant, spec.window[0]),
                        spec.parameter, spec.values(), spec.output, spec.window,
                        spec.measure == "vibration", run.writer, group, run.progress, name)
            store.save(key + "f", group[schema.LEVEL_FREE])
            store.save(key + "s", group[schema.LEVEL_STUCK])
    every = len(keys) + sum(schema.is_level(k) for k in group)
    _draw(pictures.peak, group, spec, run, keys, store.hits - hits == every)
    return _worst(statuses)


def _write_peak_curve(group: h5py.Group, curve: str, label: str, value, spec: Peak,
                      parts: list[Outcome | None], run: Run) -> tuple[str, str]:
    """One peak curve from its tasks' rows (``parts``, in value order; None: not run, after
    an interrupt): the values up to the first missing one; (status, message)."""
    done = []
    for part in parts:
        if part is None:
            break
        done.append(part)
    statuses = [(p.status, p.message) for p in done]
    if len(done) < len(parts):
        statuses.append(("interrupted", "interrupted by the user"))
    rows = [p.data for p in done if p.data]
    status, message = _worst(statuses)
    if not rows:  # interrupted before its first value
        return status, message
    data = {k: np.concatenate([r[k] for r in rows]) for k in rows[0]}
    if "stable" in data and not np.any(data["stable"] >= 0):
        del data["stable"], data["floquet"]  # no stability anywhere
    run.writer.write_group(group, curve, data, peak_identity(spec, label, value) | {
        "status": status, "message": message,
        "elapsed_s": sum(p.seconds for p in done)})
    run.writer.flush()
    return status, message


def peak_task(models: LumpedModels | AssemblyModels, c: Case, spec: Peak, label: str,
              index: int | None, *, progress: Progress, live: bool = True) -> Outcome:
    """The peak curve of the case variant ``c`` by continuation (``index`` None), or its
    value ``index`` by a sweep: a task (``tasks``) whose rows (parameter, omega, amplitude,
    complete, how; stable and floquet with ``stability``) the client joins into the curve."""
    par = spec.parameter
    values = spec.values() if index is None else spec.values()[index:index + 1]
    k = _outputs(c, (spec.output,), models)[1][0]
    lo, hi = spec.window
    vibration = spec.measure == "vibration"
    hb = models.model(c)
    base = operating_point(c, lo)
    tick = _peak_ticker(progress, spec.name, label, par)
    statuses = []
    why = undefined(hb) if spec.stability and hb.n_unknowns else ""
    if why and index in (None, 0):
        progress(f"[{spec.name}] {label}: no stability: {why}".replace("] :", "]:"))
    wanted = spec.stability and not why
    if index is None:
        try:
            pc = peak_curve(hb, par, values, k, (lo, hi), base, settings=settings(c),
                            progress=tick, vibration=vibration, stability=wanted)
        except KeyboardInterrupt:
            return Outcome({}, {}, "interrupted", "interrupted by the user")
        omega, amp, how = list(pc.omega), list(pc.amplitude), pc.how
        stability = list(pc.stability or [])
        done = [bool(np.isfinite(x)) for x in amp]
        statuses.append(("complete", "") if all(done) else
                        ("stopped", "no solution at some values"))
    else:
        v = values[0]
        r = sweep(hb, "frequency", lo, hi, base.set(par, v), settings=settings(c))
        if r.branch.status == "interrupted":
            return Outcome({}, {}, "interrupted", r.branch.message)
        wk, ak = r.peak(k, vibration=vibration) if len(r) else (np.nan, np.nan)
        stability = []
        if wanted and np.isfinite(wk):  # from the points around the top
            top = r.top(k, vibration=vibration)[0]
            near = range(max(top - 1, 0), min(top + 2, len(r)))
            stability.append(stability_at(
                hb, base.set(par, v).set("frequency", wk),
                [(r.omega[j], r.branch.x[j]) for j in near], settings(c)))
        elif wanted:
            stability.append(None)
        omega, amp, done, how = [wk], [ak], [r.branch.complete], ["swept"]
        statuses.append((r.branch.status, r.branch.message))
        tick(index, v, wk, ak, "swept")
    data = {"parameter": values, "omega": np.array(omega), "amplitude": np.array(amp),
            "complete": np.array(done), "how": np.array(how)}
    if wanted:
        data |= {"stable": np.array([-1 if s is None else int(s.stable) for s in stability],
                                    dtype=np.int8),
                 "floquet": _floquet(stability)}
    status, message = _worst(statuses)
    return Outcome(data, {}, status, message)


def run_loops(case: Case, spec: Loops, group: h5py.Group, run: Run) -> tuple[str, str]:
    """The loops of one contact law under the prescribed motion, one per amplitude (the
    contact as the case, its ``set`` applied, gives it); the picture."""
    variant = case.with_values(spec.set)
    table = next(c for c in variant.data["contacts"] if c.get("name") == spec.contact)
    amps = np.asarray(spec.amplitudes, dtype=float)
    base = contact_elements(table)
    el = type(base)(base.law, np.repeat(base.kt, amps.size, 0), np.repeat(base.kn, amps.size),
                    np.repeat(base.mu, amps.size), np.repeat(base.n0, amps.size), base.coupled)
    h = Harmonics([0, 1], spec.samples)
    motion = [spec.u] + ([spec.u2] if el.dim == 2 else []) + (
        [spec.v] if el.variable_normal else [])
    g = np.zeros((amps.size, el.n_components, 3))
    scale_v_only = el.variable_normal and spec.scale == "v"
    for j, (ca, sa) in enumerate(motion):
        is_v = el.variable_normal and j == el.n_components - 1
        factor = amps if (is_v or not scale_v_only) else np.ones_like(amps)
        g[:, j, 1], g[:, j, 2] = factor * ca, factor * sa
    r = el.evaluate(g, h, jacobian=False, histories=True)
    scaled = el.n_components - 1 if scale_v_only else 0  # the motion the amplitudes scale
    data = {"amplitude": amps, "u": r.u, "v": r.v, "T": r.T, "N": r.N,
            "dissipation": r.dissipation, "state": r.state.astype(np.int8),
            "motion_amplitude": amps * np.hypot(*motion[scaled])}
    run.writer.write_group(group, schema.curve(0), data, {
        "label": f"loops of {spec.contact}", "status": "complete", "message": "",
        "law": el.law, "contact": spec.contact, "dim": el.dim, "mu": float(base.mu[0]),
        "motion": "v" if scale_v_only else ("u_x" if el.dim == 2 else "u")})
    _draw(pictures.loops, group, spec, run)
    return "complete", ""


def _time_model(case: Case, spec: TimeIntegration):
    """(case as set, HB model, output names, indices, time model, load steps)."""
    from microslip.solve import dti

    c = case.with_values(spec.set)
    hb = lumped_model(c)
    names, idx = _outputs(c, spec.outputs)
    tm = dti.TimeModel.from_harmonic_balance(hb)
    loads = dti.LoadSteps.from_excitation(
        hb.excitation, hb.linear.n_dof, ramp_time=spec.ramp_time,
        settle_time=spec.settle_time, ramp_periods=spec.ramp_periods)
    return c, hb, names, idx, tm, loads


def run_dti(case: Case, spec: Dti, group: h5py.Group, run: Run) -> tuple[str, str]:
    """Steady responses by time integration at each frequency; the pictures."""
    from microslip.solve import dti

    name, progress = spec.name, run.progress
    c, hb, names, idx, tm, loads = _time_model(case, spec)
    H = max(hb.harmonics.orders)
    spp = spec.steps_per_period

    def tick(i, n, omega, steady):
        progress(f"[{name}] {i + 1}/{n} w = {omega:.6g} rad/s: {steady.periods} periods, "
                 f"max|{names[0]}| = {steady.amplitude[idx[0]]:.6g}"
                 + ("" if steady.converged else " (not periodic yet)"))

    kw = dict(steps_per_period=spp, max_periods=spec.max_periods,
              harmonics=min(H, (spp - 1) // 2))
    try:
        if spec.restart:
            # every frequency from fresh load steps: a stuck contact keeps the static
            # state of its history, so a sweep would carry it from one point to the next
            parts = []
            for i, wk in enumerate(spec.frequencies):
                part = dti.frequency_response(tm, loads, [wk], **kw)
                parts.append(part)
                progress(f"[{name}] {i + 1}/{len(spec.frequencies)} w = {wk:.6g} rad/s: "
                         f"{part.periods[0]} periods")
            fr = _join_responses(parts)
        else:
            fr = dti.frequency_response(tm, loads, list(spec.frequencies), progress=tick,
                                        **kw)
    except KeyboardInterrupt:
        return "interrupted", "time integration interrupted by the user"
    contacts = {}
    for ci, ct in enumerate(c.contacts_enabled()):
        contacts[ct] = {"N0": fr.N0[ci], "T0": fr.T0[ci],
                        ATTRS: {"variable_normal": _normal(hb, ct)}}
    shown = fr.amplitude[:, idx]
    if spec.measure != "peak":
        hh = Harmonics(range(fr.coefficients.shape[2] // 2 + 1), spp)
        shown = response_measure(hh, fr.coefficients[:, idx], spec.measure)
    data = {"omega": fr.omega, "amplitude": fr.amplitude[:, idx], "response": shown,
            "coefficients": fr.coefficients[:, idx], "periods": fr.periods,
            "converged": fr.converged, "seconds": fr.seconds, schema.CONTACTS: contacts}
    ok = bool(np.all(fr.converged))
    message = "" if ok else f"{int(np.sum(~fr.converged))} frequencies not periodic yet"
    run.writer.write_group(group, schema.curve(0), data, {
        "label": "time integration", "status": "complete" if ok else "stopped",
        "message": message, "outputs": names, "steps_per_period": spp,
        "measure": spec.measure})
    _draw(pictures.dti, group, spec, run)
    return ("complete" if ok else "stopped"), message


def _join_responses(parts):
    """One FrequencyResponse from single-frequency ones."""
    first = parts[0]
    cat = {f: np.concatenate([getattr(p, f) for p in parts])
           for f in ("omega", "amplitude", "coefficients", "periods", "converged",
                     "dissipation", "seconds")}
    n0 = tuple(np.concatenate([p.N0[c] for p in parts]) for c in range(len(first.N0)))
    t0 = tuple(np.concatenate([p.T0[c] for p in parts]) for c in range(len(first.T0)))
    return type(first)(cat["omega"], cat["amplitude"], cat["coefficients"], cat["periods"],
                       cat["converged"], n0, t0, cat["dissipation"], cat["seconds"],
                       parts[-1].end)


def run_transient(case: Case, spec: Transient, group: h5py.Group, run: Run
                  ) -> tuple[str, str]:
    """The two load steps as time histories; the picture."""
    from microslip.solve import dti

    c, hb, names, idx, tm, loads = _time_model(case, spec)
    t0 = time.perf_counter()
    steps = dti.load_steps(tm, loads, spec.frequency, steps_per_period=spec.steps_per_period)
    run.progress(f"[{spec.name}] load steps integrated in {time.perf_counter() - t0:.2f} s")
    for k, (label, tr) in enumerate(zip(("load step 1", "load step 2"), steps)):
        if tr is None:
            continue
        data = {"t": tr.t, "q": tr.q[:, idx], "F": tr.F[:, idx],
                schema.CONTACTS: {ct.name: {"T": h.T, "N": h.N, "state": h.state,
                                            ATTRS: {"mu": float(ct.elements.mu[0])}}
                                  for ct, h in zip(hb.contacts, tr.contacts)}}
        run.writer.write_group(group, schema.step(k + 1), data, {
            "label": label, "status": "complete", "message": "", "outputs": names,
            "contacts": _attr_list([ct.name for ct in hb.contacts])})
    _draw(pictures.transient, group, spec, run)
    return "complete", ""


def _worst(statuses: list[tuple[str, str]]) -> tuple[str, str]:
    for key in ("interrupted", "stopped", "failed"):
        for s, m in statuses:
            if s == key:
                return s, m
    return "complete", ""


def run_modes(case: Case, spec: Modes, group: h5py.Group, run: Run) -> tuple[str, str]:
    """The lowest modes of every reduced body, unreduced (held as its reduction holds it)
    and reduced, per nodal diameter (``fe.modes``): results.h5 <name>/<body>/nd<h> (a body
    without cyclic symmetry: <body>/body) and the picture of the reduction's error."""
    from microslip.case.reduction_table import body_specs
    from microslip.fe import fem
    from microslip.fe.modes import body_modes

    mesh, result = run.structure
    red = case.reduction_table
    bodies = {b.body: b for b in body_specs(mesh, red)}
    worst = 0.0
    for name, models in result.models.items():
        body = bodies[name]
        assembled = fem.assemble(mesh, name, body.material, body.order)
        is_cyclic = name in mesh.cyclic
        parent = group.create_group(name)
        for h, model in (models.items() if is_cyclic else list(models.items())[:1]):
            t = time.perf_counter()
            found = body_modes(mesh, body, model, spec.count, h if is_cyclic else None,
                               spec.shapes, red.factorization, assembled)
            error = found.relative_error
            worst = max(worst, float(np.abs(error).max(initial=0.0)))
            data = {"frequencies_hz": found.frequencies_hz, "reduced_hz": found.reduced_hz,
                    "relative_error": error, "nodes": found.nodes}
            if found.shapes is not None:
                data["shapes"] = found.shapes.astype(np.complex64 if np.iscomplexobj(
                    found.shapes) else np.float32)
            where = schema.nodal_diameter(h) if is_cyclic else "body"
            run.writer.write_group(parent, where, data, {
                "n_free": found.n_free, "seconds": time.perf_counter() - t,
                "reduced_modes": model.n_modes, "master_dofs": 3 * len(model.master_nodes)})
            run.progress(f"[{spec.name}] {name}" + (f" ND {h}" if is_cyclic else "")
                         + f" ({found.n_free} DOFs, {time.perf_counter() - t:.1f} s): f [Hz] "
                         + " ".join(f"{x:.6g}" for x in found.frequencies_hz[:6])
                         + f"; reduced model's error at most "
                         f"{float(np.abs(error).max(initial=0.0)):.2g}")
    if isinstance(run.models, AssemblyModels):
        _assembly_modes(case, spec, group, run)
    _draw(pictures.modes, group, spec, run)
    return "complete", f"(the reduced models' frequency error at most {worst:.2g})"


def _assembly_modes(case: Case, spec: Modes, group: h5py.Group, run: Run) -> None:
    """The reduced assembly's natural frequencies on each dynamic harmonic's nodal diameter,
    every contact stuck and the cyclic bodies free of contact (the FRF's linear limits'
    resonances): results.h5 <name>/assembly/order<n>."""
    variant = case.with_values(spec.set)
    cm = run.models.assembly(variant)
    point = operating_point(variant)
    parent = group.create_group(schema.ASSEMBLY_MODES)
    for order in (o for o in cm.hb.harmonics.orders if o > 0):
        stuck, free = (cm.linear_frequencies(point, order, springs, spec.count)
                       for springs in ("stuck", "free"))
        run.writer.write_group(parent, f"order{order}", {"stuck_hz": stuck, "free_hz": free},
                               {"order": order})
        run.progress(f"[{spec.name}] assembly, harmonic {order}: stuck f [Hz] "
                     + " ".join(f"{x:.6g}" for x in stuck[:6]) + "; free (no contact) "
                     + " ".join(f"{x:.6g}" for x in free[:6]))


#: One runner per analysis type: (case, its spec, its results group, the run's shared
#: parts) -> (status, message).
RUNNERS = {"frf": run_frf, "peak": run_peak, "uncertainty": run_uncertainty,
           "loops": run_loops, "dti": run_dti, "transient": run_transient,
           "modes": run_modes}
