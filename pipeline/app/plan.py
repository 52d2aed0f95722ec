"""What a run will do, before it does it (``microslip run --dry-run``): each stage, whether it
comes from a cache (meshes and reduced models in the shared cache, ``app.cache``; the
curves in ``<out>/cache``) or runs, and a rough estimate of its time and memory.

Nothing is computed: a meshed case is meshed (a few seconds, unless its mesh is in the
shared cache) because the reduced models' cache names depend on the mesh. The time
estimates scale measured figures of this project (two cores; see the README's benchmarks) by
the sizes of the case: they are good to a factor of about two, enough to tell a minute from
an hour.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from microslip.case import (
    Case,
    curve_variants,
    harmonics,
    operating_point,
    sizes,
    task_seconds,
)
from microslip.case.estimate import (
    LINEAR_EXPONENT,
    POINT_UNKNOWNS,
    START_S,
    analysis_seconds,
)
from microslip.laws import kernels_cached
from microslip.solve.memory import memory_text

from .cache import SharedCache, built_mesh
from .store import CurveStore

#: Measured anchors of the estimates (two quiet cores, the shipped cases and imported blocks
#: of 1.5k-220k DOFs; the harmonic balance's, the pictures' and the start's are
#: case.estimate's): a Craig-Bampton model per 1000 vertex nodes of its body, P2
#: tetrahedra [s] (P1 LINEAR_ELEMENTS times; a complex nodal diameter COMPLEX_ND times,
#: hexahedra and wedges SOLID_ELEMENTS times: their denser rows); a linear limit curve of
#: 1296 unknowns [s] (growing as unknowns^1.8); a Gmsh mesh and its three previews [s].
REDUCTION_S_PER_KNODE = 10.0
LINEAR_ELEMENTS = 0.06
COMPLEX_ND = 1.5
SOLID_ELEMENTS = 1.3
#: Peak memory of a Craig-Bampton model of n DOFs and m master nodes (imported blocks of
#: 5k-220k DOFs in tetrahedra and hexahedra, both orders, measured as the run's peak
#: resident size): the process itself, PROCESS_BYTES, plus per DOF the sparse factor's
#: FACTOR_BYTES x (n / 1e5)^FILL_GROWTH (SOLID_ELEMENTS_MEMORY x that for hexahedra and
#: wedges: denser rows) and the dense columns, COLUMN_BYTES per master DOF and mode.
PROCESS_BYTES = 0.45e9
FACTOR_BYTES = 17e3
FILL_GROWTH = 0.15
SOLID_ELEMENTS_MEMORY = 1.3
COLUMN_BYTES = 24.0
#: The fixed-interface modes "auto" keeps, for the estimates: at least AUTO_MODES (the shipped
#: bodies: 20-80), more with many masters (their fixed interface stiffens the body, so its
#: 10th frequency, and the cut-off above it, rise: 664 modes for 935 master nodes)
AUTO_MODES = 60
AUTO_MODES_PER_MASTER = 0.7
#: The dense work of a reduction with c = 3 m + modes columns (the static and fixed-interface
#: modes, their orthogonalization and the reduced matrices): this x n c^2 [s] (an imported
#: block of 60k DOFs: 483 s with 2805 master DOFs and 664 modes, 70 s with 198 and 54)
DENSE_S = 5.7e-10
LINEAR_S = 10.0
#: The unreduced bodies' lowest modes (a ``modes`` analysis) against their reduction [-]
MODES_SHARE = 0.5
MESH_S = 3.0
PREVIEWS_S = 3.0


#: The reference workload: the single-DOF Jenkins oscillator's FRF (``microslip demo``'s;
#: harmonics 0-3, 64 samples, 0.5..2.5 rad/s: 93 points) in one process, one BLAS thread;
#: REFERENCE_S is its time on the two quiet cores the anchors were measured on [s] (medians
#: of 5: 0.255-0.261 s; with both cores busy with two other processes, 1.5-1.9 x that).
REFERENCE = {"model": {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0], "damping": [0.02]},
             "contacts": [{"name": "wall", "law": "A", "kt": 3.0, "mu": 1.0, "n0": 0.05,
                           "u": {"x": 1.0}}],
             "loads": [{"dof": "x", "amplitude": 0.1, "harmonic": 1}],
             "harmonics": {"max": 3, "samples": 64}}
REFERENCE_S = 0.26
#: The machine factor's floor: a faster machine is not trusted to be faster still.
FACTOR_FLOOR = 0.5


def machine_factor(repeat: int = 3) -> float:
    """How much longer than on the anchors' quiet machine work takes here now: the median
    time of the reference workload (after one run that loads it) over REFERENCE_S, at least
    0.5. 1 when the contact kernels are not compiled yet (a dry run does not compile them)."""
    import time

    from threadpoolctl import threadpool_limits

    from microslip.case import Case, lumped_model
    from microslip.solve.linear import OperatingPoint
    from microslip.solve.response import sweep

    if not kernels_cached():
        return 1.0
    hb = lumped_model(Case(REFERENCE, "reference"))
    times = []
    with threadpool_limits(limits=1, user_api="blas"):
        for _ in range(repeat + 1):
            t = time.perf_counter()
            sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5))
            times.append(time.perf_counter() - t)
    return max(FACTOR_FLOOR, float(np.median(times[1:])) / REFERENCE_S)


@dataclass(frozen=True)
class Stage:
    """One step of a run: ``cached`` ones are read, the others run for ~``seconds``;
    ``work``: its seconds were it computed (a reduction's, which the modes scale with)."""

    name: str
    cached: bool
    seconds: float = 0.0
    nbytes: int = 0
    detail: str = ""
    work: float = 0.0


def plan(case: Case, out: Path, cache: bool = True, shared: SharedCache | None = None
         ) -> list[Stage]:
    """The stages of a run of ``case`` into ``out`` (see the module); ``cache`` False: the
    curves are computed afresh (``run --no-cache``); ``shared``: the cache of meshes and
    reduced models (default: the environment's)."""
    stages: list[Stage] = [Stage("start: Python and microslip loaded", False, START_S, 0,
                                 "" if kernels_cached() else "and the contact kernels "
                                 "compiled once (first run: ~25-100 s more)")]
    data = case.data
    reduction_stages: list[Stage] = []
    if "geometry" in data:
        shared = shared or SharedCache.from_environment()
        mesh, kept = built_mesh(case.geometry_table, shared)
        imported = case.geometry_table.imported
        what = "mesh read" if imported else "Gmsh mesh"
        stages.append(Stage(f"geometry: {what} and previews", False,
                            PREVIEWS_S + (0.0 if kept or imported else MESH_S), 0,
                            f"{mesh.points.shape[0]} nodes, {mesh.element_summary()}; "
                            + ("mesh from the shared cache" if kept else "every run")))
        if "reduction" in data:
            orders = harmonics(case).orders if "harmonics" in data else None
            reduction_stages = _reduction(mesh, case.reduction_table, shared.models, orders,
                                          case.draws_shapes)
            stages += reduction_stages
    store = CurveStore(out / "cache" / "curves" if cache else None)
    kinds = case.known_kinds
    by_name = {s.analysis: s for s in sizes(data, kinds)}
    for spec in case.analysis_specs:
        size = by_name.get(spec.name)
        context = PlanContext(store, size.unknowns if size else 0, size.nbytes if size else 0,
                              tuple(reduction_stages))
        kind = kinds.of(spec)
        stages += kind.plan(case, spec, context) if kind.plan else [Stage(
            f"{spec.name}: {spec.type}", False, task_seconds(data, spec, kinds=kinds)
            + analysis_seconds(data, spec, kinds), context.nbytes, "not cached")]
    return stages


@dataclass(frozen=True)
class PlanContext:
    """What an analysis' dry run sees beyond its case and spec: the curve store, its
    estimated unknowns and memory, and the reduction's stages (what its work scales with)."""

    store: CurveStore
    unknowns: int
    nbytes: int
    reductions: tuple[Stage, ...] = ()


def curve_stages(case: Case, spec, context: PlanContext, methods: tuple[str, ...],
                 key: Callable[[Case, str], str], per_curve: int = 1) -> list[Stage]:
    """The stages of an analysis of curves (a family value and a method each: a task each,
    ``per_curve`` tasks of a curve's estimate each), each cached where the store has its
    ``key(variant, method)``; its pictures first."""
    data = case.data
    stages = [Stage(f"{spec.name}: pictures", False, analysis_seconds(data, spec,
                                                                       case.known_kinds),
                    0, "every run")]
    for j, (c, label, _) in enumerate(curve_variants(case, spec)):
        seconds = task_seconds(data, spec, c.data, case.known_kinds) * per_curve
        for method in methods:
            cached = context.store.has(key(c, method))
            what = ", ".join(x for x in (label, method if len(methods) > 1 else "") if x)
            stages.append(Stage(f"{spec.name}: curve {j + 1}" + (f" ({what})" if what else ""),
                                cached, 0.0 if cached else seconds, context.nbytes,
                                f"{context.unknowns:,} unknowns"))
    return stages


def linear_limit_stages(case: Case, spec, context: PlanContext) -> list[Stage]:
    """The linear limits of an assembly case's frequency sweep (free, and stuck at each
    mass the curves take)."""
    masses = {operating_point(c, spec.omega).mass_multiplier
              for c, _, _ in curve_variants(case, spec)}
    seconds = LINEAR_S * (context.unknowns / POINT_UNKNOWNS) ** LINEAR_EXPONENT
    return [Stage(f"{spec.name}: linear limits (free, stuck x {len(masses)})", False,
                  seconds * (1 + len(masses)), 0, "each reused from the cache when unchanged")]


def modes_stage(spec, context: PlanContext, pictures: float) -> Stage:
    """The modes of the unreduced bodies: a share of the reduction's work, every run."""
    return Stage(f"{spec.name}: modes", False, pictures + MODES_SHARE * sum(
        s.work for s in context.reductions), 0, "the unreduced bodies, every run")


def samples_stage(case: Case, spec, context: PlanContext, keys: list[str],
                  noun: str = "samples") -> Stage:
    """A study's tasks (an uncertainty study's samples; ``keys``: each one's store key) as
    one stage, named by ``noun``: those to compute, in one process."""
    todo = sum(not context.store.has(k) for k in keys)
    each = task_seconds(case.data, spec, kinds=case.known_kinds)
    return Stage(f"{spec.name}: {len(keys)} {noun}", todo == 0, todo * each, context.nbytes,
                 f"{todo} to compute (~{each:.2g} s each in one process; a cluster of n "
                 f"workers ~n x faster), {context.unknowns:,} unknowns")


def _reduction(mesh, red, cache: Path | None, orders, surfaces: bool = False
               ) -> list[Stage]:
    """Per body and nodal diameter: the reduced model's cache file exists, or it runs
    (``cache`` None: none is cached)."""

    from microslip.case.reduction_table import body_specs, needed_nodal_diameters
    from microslip.fe import bodies

    sectors = {b.sectors for b in mesh.cyclic.values()}
    nds = needed_nodal_diameters(red, max(sectors), orders) if sectors else (0,)
    stages = []
    cyclic_cached = True
    for spec in sorted(body_specs(mesh, red, surfaces), key=lambda s: s.body not in mesh.cyclic):
        nodes = mesh.body_nodes(spec.body).size
        seconds = (REDUCTION_S_PER_KNODE * nodes / 1000
                   * (1.0 if spec.order == 2 else LINEAR_ELEMENTS))
        if len(mesh.hexahedra) + len(mesh.wedges):
            seconds *= SOLID_ELEMENTS
        is_cyclic = spec.body in mesh.cyclic
        sectors = mesh.cyclic[spec.body].sectors if is_cyclic else 0
        n, columns, nbytes = _reduction_size(mesh, spec)
        seconds += DENSE_S * n * columns**2
        for h in (nds if is_cyclic else (None,)):
            complex_nd = is_cyclic and 0 < h < sectors / 2
            if not is_cyclic and spec.f_max is None and spec.n_modes == "auto":
                if not cyclic_cached:  # its modes follow the cyclic bodies' reduced models
                    stages.append(Stage(f"reduction: {spec.body}", False, seconds, nbytes,
                                        "after the cyclic bodies (its mode count follows "
                                        "theirs)", seconds))
                    continue
                spec = _with_reference(spec, mesh, red, nds, cache, surfaces)
            cached = cache is not None and bodies.model_path(mesh, spec, h, cache).is_file()
            cyclic_cached = cyclic_cached and (cached or not is_cyclic)
            where = f"{spec.body} ND {h}" if is_cyclic else spec.body
            work = seconds * (COMPLEX_ND if complex_nd else 1.0)
            stages.append(Stage(f"reduction: {where}", cached, 0.0 if cached else work,
                                0 if cached else int(nbytes * (2 if complex_nd else 1)),
                                f"{nodes} vertex nodes, P{spec.order}", work))
    return stages


def reduction_estimate(mesh, red, orders=None) -> tuple[float, float]:
    """(seconds on the reference machine, peak bytes) of reducing every body of ``mesh`` as
    ``red`` says, none cached (``check``'s line)."""
    stages = _reduction(mesh, red, None, orders)
    return sum(s.work for s in stages), max((s.nbytes for s in stages), default=0)


def _reduction_size(mesh, spec) -> tuple[int, int, float]:
    """(DOFs of the body, columns of its reduction basis: 3 x master nodes + modes, "auto"
    as AUTO_MODES and AUTO_MODES_PER_MASTER say, peak memory [bytes] of its reduction by the
    anchors above, real: a complex nodal diameter doubles it)."""
    from microslip.fe import bodies
    from microslip.geometry import elements

    cells = mesh.body_cells(spec.body)
    edges = 0
    if spec.order == 2:
        pairs = np.concatenate([np.sort(c[:, elements.EDGES[k]].reshape(-1, 2), axis=1)
                                for k, c in cells.items()])
        edges = len(np.unique(pairs, axis=0))
    masters = bodies.spec_nodes(mesh, spec)[0].size
    modes = (spec.n_modes if isinstance(spec.n_modes, int)
             else max(AUTO_MODES, int(AUTO_MODES_PER_MASTER * masters)))
    n, columns = 3 * (mesh.body_nodes(spec.body).size + edges), 3 * masters + modes
    solid = SOLID_ELEMENTS_MEMORY if set(cells) - {"tetra"} else 1.0
    per_dof = FACTOR_BYTES * solid * (n / 1e5) ** FILL_GROWTH + COLUMN_BYTES * columns
    return n, columns, PROCESS_BYTES + n * per_dof


def _with_reference(spec, mesh, red, nds, cache: Path, surfaces: bool = False):
    """A non-cyclic body's spec with the f_max its run would infer from the cyclic bodies'
    (cached) models."""
    from dataclasses import replace

    from microslip.case.reduction_table import body_specs
    from microslip.fe import bodies, reduced_model

    models = [reduced_model.ReducedModel.load(bodies.model_path(mesh, s, h, cache))
              for s in body_specs(mesh, red, surfaces) if s.body in mesh.cyclic for h in nds]
    f_ref = reduced_model.reference_frequency(models)
    return spec if f_ref is None else replace(spec, f_max=f_ref)


def scaled(stages: list[Stage], factor: float) -> list[Stage]:
    """The stages with their times ``factor`` times longer (``machine_factor``)."""
    return [replace(s, seconds=s.seconds * factor) for s in stages]


def text(stages: list[Stage], factor: float = 1.0) -> str:
    """The plan as a table, with the totals (``factor``: the machine's, already applied to
    the stages, said at the end)."""
    rows = [f"{'stage':<58} {'':>7} {'time':>9} {'memory':>9}"]
    for s in stages:
        state = "cached" if s.cached else "runs"
        time = "-" if s.cached else _duration(s.seconds)
        mem = memory_text(s.nbytes).lstrip("~") if s.nbytes else "-"
        rows.append(f"{s.name[:58]:<58} {state:>7} {time:>9} {mem:>9}"
                    + (f"  {s.detail}" if s.detail else ""))
    total = sum(s.seconds for s in stages if not s.cached)
    peak = max((s.nbytes for s in stages), default=0)
    runs = sum(not s.cached for s in stages)
    rows.append(f"{runs} of {len(stages)} stages run, {_duration(total)} in all (rough: "
                f"within about 2x of a run in one process; a cluster of n workers takes up to "
                f"n x less for the curves), peak memory {memory_text(peak).lstrip('~')}")
    rows.append(f"the times are the shipped cases' on two quiet cores, x {factor:.2g}: this "
                "machine's speed now (a reference sweep timed just before), which a busier "
                "machine later changes")
    return "\n".join(rows)


def _duration(seconds: float) -> str:
    if seconds < 60:
        return f"~{seconds:.0f} s"
    return f"~{seconds / 60:.1f} min"
