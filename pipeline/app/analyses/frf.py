"""``type = "frf"``: response curves in a parameter (frequency, excitation, preload, mass),
one per family value and method, with their contact states, stability and bifurcations and,
on an assembly case, the linear limits and the contact maps at chosen points (Firrone &
Zucca Figs. 4-8, 14-17, 22-26)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import ClassVar

import h5py
import numpy as np

from microslip.case import Case, curve_variants, operating_point, settings, task_seconds
from microslip.case import analysis_rules as rules
from microslip.case.checks import is_number, number
from microslip.case.estimate import (
    CURVE_POINTS,
    MAP_DRAW_S,
    MAP_SOLVES,
    balance_points,
    point_seconds,
)
from microslip.case.kinds import AnalysisKind, Checking
from microslip.case.specs import MEASURES, Analysis, Family
from microslip.draw import pictures
from microslip.results import schema
from microslip.results.writer import ATTRS, sampling_warning
from microslip.solve.bifurcation import find_bifurcations
from microslip.solve.linear import PARAMETERS
from microslip.solve.response import Response, response_measure, sweep
from microslip.solve.stability import hill_stability, undefined

from ..limits import linear_limits
from ..models import AssemblyModels, LumpedModels
from ..plan import PlanContext, Stage, curve_stages, linear_limit_stages
from ..running import (
    Progress,
    Run,
    cached_curve,
    computed_curves,
    draw_analysis,
    floquet,
    interrupted,
    member_identity,
    outputs,
    ticker,
    worst,
)
from ..solutions import (
    contact_data,
    contact_rows,
    map_groups,
    map_solutions,
    patch_data,
    response_at,
    sampling_change,
)
from ..store import CurveStore
from ..tasks import Outcome, Task

#: continuation methods of an frf; ``natural-down`` sweeps from stop to start
METHODS = ("arclength", "natural", "natural-down")

#: the maps an frf of an assembly case can draw at its map points
MAP_TYPES = ("status", "normal_load", "shape")

@dataclass(frozen=True, kw_only=True)
class Frf(Analysis):
    """A response curve: ``parameter`` from ``start`` to ``stop`` by each of ``method``
    (one curve each), at the fixed ``frequency`` (rad/s) when the parameter is not the
    frequency; ``outputs``: DOF or output names (None: every output); ``maps``: where a
    assembly case draws contact maps ("peak" or parameter values), ``map_types`` which;
    ``stability``: Hill's stability at every point and the bifurcations between them."""

    type: ClassVar[str] = "frf"
    start: float
    stop: float
    parameter: str = "frequency"
    frequency: float | None = None
    method: tuple[str, ...] = ("arclength",)
    outputs: tuple[str, ...] | None = None
    measure: str = "peak"
    normalise: bool = False
    family: Family | None = None
    maps: tuple[str | float, ...] = ()
    map_types: tuple[str, ...] = ("status",)
    stability: bool = True

    @property
    def omega(self) -> float:
        """The frequency (rad/s) the curve starts at (a frequency sweep) or holds."""
        return self.start if self.parameter == "frequency" else self.frequency

    @property
    def shapes(self) -> bool:
        """Whether deformed shapes are drawn (and so recovered) at the map points."""
        return bool(self.maps) and "shape" in self.map_types


def check(c: Checking) -> None:
    """An frf's own rules: its parameter and range (a fixed frequency for the others), its
    methods, family, maps, flags, measure and outputs."""
    a = c.table
    par = a.get("parameter")
    rules.sweep_range(c, PARAMETERS)
    if par != "frequency" and not number(f"{c.pre}.frequency", a.get("frequency"), c.out,
                                         positive=True):
        c.out.append(f"{c.pre}.frequency: the fixed frequency (rad/s) of a {par} sweep")
    methods = a["method"] if isinstance(a["method"], list) else [a["method"]]
    for m in methods:
        if m not in METHODS:
            c.out.append(f"{c.pre}.method = {m!r}: expected one of {list(METHODS)} (or a list "
                         "of them: one curve each)")
    rules.family_faults(c)
    maps_faults(c)
    rules.flag(c, "stability", " (Hill's stability at every point, and the bifurcations)")
    rules.flag(c, "normalise", " (the response per unit of the excitation multiplier)")
    rules.measure_faults(c, MEASURES)
    rules.output_faults(c)


def maps_faults(c: Checking) -> None:
    """``maps`` and ``map_types`` of an frf, where given."""
    if "maps" in c.given or "map_types" in c.given:
        _map_faults(c.pre, c.table, c.data, c.out)


def _map_faults(pre: str, a: dict, data: dict, out: list[str]) -> None:
    """``maps``: where an frf draws its contact maps ("peak", or parameter values: every
    solution there); ``map_types``: which maps."""
    if "assembly" not in data:
        out.append(f"{pre}.maps: contact maps need contact patches: a [assembly] case")
        return
    where = a["maps"]
    lo, hi = sorted((a.get("start", 0.0), a.get("stop", 0.0)))
    if not isinstance(where, list):
        out.append(f"{pre}.maps = {where!r}: expected a list of 'peak' and parameter values")
        where = []
    for x in where:
        if x != "peak" and not (is_number(x) and lo <= x <= hi):
            out.append(f"{pre}.maps: {x!r} is neither 'peak' nor a parameter value in the "
                       f"range {lo:g}..{hi:g}")
    kinds = a["map_types"]
    if not (isinstance(kinds, list) and all(k in MAP_TYPES for k in kinds)):
        out.append(f"{pre}.map_types = {kinds!r}: expected a list of {list(MAP_TYPES)}")
    elif "shape" in kinds and isinstance(data["assembly"].get("mistuning"), dict):
        # (every sector's surface in the annulus' coordinates: tens of GB at 48 blades)
        out.append(f"{pre}.map_types: 'shape' is not drawn on the whole disk "
                   "([assembly.mistuning]); its maps are 'status' and 'normal_load'")


def seconds(data: dict, spec: Frf, variant: dict | None = None) -> float:
    """One curve: CURVE_POINTS points and its map points (MAP_SOLVES solves and the
    pictures each)."""
    points = balance_points(data, spec, variant)  # (each curve's sizes, found once)
    t = max(point_seconds(*p, stability=spec.stability) for p in points)
    solve = max(point_seconds(*p, stability=False) for p in points)
    maps = len(spec.maps) * (MAP_SOLVES * solve + MAP_DRAW_S * len(spec.map_types))
    return CURVE_POINTS * t + maps


def plan(case: Case, spec: Frf, context: PlanContext) -> list[Stage]:
    """Its pictures, each curve (cached or not), the linear limits of an assembly case's
    frequency sweep."""
    stages = curve_stages(case, spec, context, spec.method,
                          lambda c, method: frf_key(context.store, c, spec, method))
    if "assembly" in case.data and spec.parameter == "frequency":
        stages += linear_limit_stages(case, spec, context)
    return stages


def draws_shapes(spec: Frf) -> bool:
    """Deformed shapes at its map points recover every body's outer surface."""
    return spec.shapes


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
            kept = cached_curve(store, key, group, curve, f"{which}: {{}} points", progress,
                                 member_identity(spec, tag, value))
            if kept:
                statuses[j] = kept
            else:
                tasks.append(Task(frf_task, (variant, spec, method, tag, value, which), which,
                                  each))
                targets.append((j, key, curve))
            j += 1
    statuses |= computed_curves(run, group, tasks, targets, f"[{name}] ")
    for k in sorted(statuses):
        written = k >= 0 and schema.curve(k) in group  # a failed task has no curve
        coarse = sampling_warning(group[schema.curve(k)]) if written else ""
        if coarse:
            progress(f"warning: {whiches[k]}: {coarse}")
    done = [statuses[k] for k in sorted(statuses)]
    if isinstance(run.models, AssemblyModels) and spec.parameter == "frequency" and done \
            and not interrupted(done):
        linear_limits(run.models, case, spec, run.writer, group, store, progress)
    every = len(keys) + sum(schema.is_linear(k) for k in group)
    draw_analysis(pictures.frf, group, spec, run, keys, store.hits - hits == every)
    return worst(done)


def frf_task(models: LumpedModels | AssemblyModels, c: Case, spec: Frf, method: str, tag: str,
             value, which: str, *, progress: Progress, live: bool = True) -> Outcome:
    """One FRF branch (and its map points) of the case variant ``c``: a task (``tasks``);
    ``live`` False leaves out the per-point ticks."""
    par, measure, wanted = spec.parameter, spec.measure, list(spec.maps)
    names, idx = outputs(c, spec.outputs, models)
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
    per_point, loops = contact_rows(r)  # every contact, once per point
    contacts = contact_data(r, per_point, loops)
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
        data[schema.PATCHES] = patch_data([patch_states(names_c, cm.points, p)
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
    attrs = member_identity(spec, tag, value) | {
        "method": method, "measure": measure, "status": b.status, "message": b.message,
        "turning_points": b.turning_points, "elapsed_s": elapsed, "outputs": names,
        "harmonic_orders": list(hb.harmonics.orders), "samples": hb.harmonics.n_samples,
        "mass_multiplier": base.mass_multiplier, "excitation": base.excitation,
        "normalised": spec.normalise}
    done = f"{which}: {len(r)} points, {b.status} ({elapsed:.2f} s) {b.message}".rstrip()
    return Outcome(data, attrs, b.status, b.message, (done,))


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
    exponents = floquet(points)
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
    return {"stable": stable, "floquet": exponents, schema.BIFURCATIONS: {
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


KIND = AnalysisKind("frf", Frf, check, seconds, run_frf, pictures.frf, plan=plan, kernels=True,
                    assembly=True, pictures_per_output=True, notes=True,
                    surfaces=draws_shapes)
