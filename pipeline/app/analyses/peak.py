"""``type = "peak"``: the largest response over a frequency window against a parameter
(excitation, preload, mass): the performance and optimization curves of Firrone & Zucca
Figs. 6 and 22, followed by continuation or a sweep per value, with the free and fully stuck
levels on an assembly case."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import h5py
import numpy as np

from microslip.case import Case, curve_variants, operating_point, settings, task_seconds
from microslip.case import analysis_rules as rules
from microslip.case.checks import number
from microslip.case.estimate import CURVE_POINTS, PEAK_SOLVES, balance_point_seconds
from microslip.case.kinds import AnalysisKind, Checking
from microslip.case.specs import Analysis, Family
from microslip.draw import pictures
from microslip.results import schema
from microslip.solve.peaks import peak_curve, stability_at
from microslip.solve.response import sweep
from microslip.solve.stability import undefined

from ..limits import LEVEL_POINTS, peak_levels
from ..models import AssemblyModels, LumpedModels
from ..plan import PlanContext, Stage, curve_stages
from ..running import (
    Progress,
    Run,
    cached_curve,
    draw_analysis,
    execute,
    floquet,
    interrupted,
    outputs,
    worst,
)
from ..tasks import Outcome, Task

#: what a peak curve sweeps
PEAK_PARAMETERS = ("excitation", "preload", "mass")

@dataclass(frozen=True, kw_only=True)
class Peak(Analysis):
    """The largest ``measure`` of ``output`` over the frequency ``window`` (rad/s) at
    ``points`` values of ``parameter`` from ``start`` to ``stop`` (``spacing`` linear or
    log), each found by ``tracking`` (continuation from the last peak, or a sweep per
    value); ``levels``: the free and fully stuck peaks too (an assembly case);
    ``stability``: Hill's stability of each peak's solution."""

    type: ClassVar[str] = "peak"
    parameter: str
    start: float
    stop: float
    window: tuple[float, float]
    output: str
    points: int = 25
    spacing: str = "linear"
    tracking: str = "continuation"
    measure: str = "peak"
    levels: bool = False
    family: Family | None = None
    stability: bool = True

    def values(self) -> np.ndarray:
        """(points,) the parameter values of each curve."""
        space = np.geomspace if self.spacing == "log" else np.linspace
        return space(self.start, self.stop, self.points)


def check(c: Checking) -> None:
    """A peak curve's own rules: its parameter and range, window, output, points, tracking,
    spacing, family, flags and measure."""
    a, pre = c.table, c.pre
    ok = rules.sweep_range(c, PEAK_PARAMETERS)
    rules.window_faults(c)
    rules.output_fault(c)
    rules.sector_only(c)
    number(f"{pre}.points", a["points"], c.out, positive=True, integer=True)
    if a["tracking"] not in ("continuation", "sweep"):
        c.out.append(f"{pre}.tracking = {a.get('tracking')!r}: expected 'continuation' (the "
                     "peak followed from value to value) or 'sweep' (a full FRF per value)")
    sp = a["spacing"]
    if sp not in ("linear", "log"):
        c.out.append(f"{pre}.spacing = {sp!r}: expected 'linear' or 'log'")
    elif sp == "log" and ok and min(a["start"], a["stop"]) <= 0:
        c.out.append(f"{pre}.spacing = 'log' needs start and stop > 0")
    rules.family_faults(c)
    rules.flag(c, "stability", " (Hill's stability at every point, and the bifurcations)")
    rules.measure_faults(c, ("peak", "vibration"))
    rules.flag(c, "levels", " (the free and fully stuck peak levels, an assembly case)")


def seconds(data: dict, spec: Peak, variant: dict | None = None) -> float:
    """One curve followed by continuation (PEAK_SOLVES solves a value), or one value found
    by a sweep (a curve of CURVE_POINTS points)."""
    t = balance_point_seconds(data, spec, variant)
    if spec.tracking == "sweep":
        return CURVE_POINTS * t
    return spec.points * PEAK_SOLVES * t


def plan(case: Case, spec: Peak, context: PlanContext) -> list[Stage]:
    """Its pictures and each curve (a task per value with ``tracking = "sweep"``)."""
    return curve_stages(case, spec, context, ("continuation",),
                        lambda c, method: context.store.key(c.data, spec.table(), curve="peak"),
                        spec.points if spec.tracking == "sweep" else 1)


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
        kept = cached_curve(store, key, group, schema.curve(j),
                             f"[{name}] {label or 'curve'}: {{}} values", run.progress,
                             peak_identity(spec, label, value))
        if kept:
            statuses.append(kept)
            continue
        curves.append((key, schema.curve(j), label, value))
        tasks += [Task(peak_task, (variant, spec, label, i if n > 1 else None),
                       f"[{name}] {label or 'curve'}", each) for i in range(n)]
    rows: dict[int, Outcome] = {}

    def keep(i: int, outcome: Outcome) -> None:
        rows[i] = outcome
        for line in outcome.lines:
            run.progress(line)

    if execute(run, tasks, f"[{name}] ", keep):
        statuses.append(("interrupted", "interrupted by the user"))
    for k, (key, curve, label, value) in enumerate(curves):
        status, message = _write_peak_curve(group, curve, label, value, spec,
                                            [rows.get(k * n + i) for i in range(n)], run)
        statuses.append((status, message))
        if status in ("complete", "stopped"):
            store.save(key, group[curve])
    if spec.levels and isinstance(models, AssemblyModels) and not interrupted(statuses):
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
    draw_analysis(pictures.peak, group, spec, run, keys, store.hits - hits == every)
    return worst(statuses)


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
    status, message = worst(statuses)
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


def peak_identity(spec: Peak, label: str, value) -> dict:
    """The attributes of a peak curve that say which analysis and member it is."""
    return {"label": label or f"peak of {spec.output}", "family_value": value or ""}


def peak_task(models: LumpedModels | AssemblyModels, c: Case, spec: Peak, label: str,
              index: int | None, *, progress: Progress, live: bool = True) -> Outcome:
    """The peak curve of the case variant ``c`` by continuation (``index`` None), or its
    value ``index`` by a sweep: a task (``tasks``) whose rows (parameter, omega, amplitude,
    complete, how; stable and floquet with ``stability``) the client joins into the curve."""
    par = spec.parameter
    values = spec.values() if index is None else spec.values()[index:index + 1]
    k = outputs(c, (spec.output,), models)[1][0]
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
                 "floquet": floquet(stability)}
    status, message = worst(statuses)
    return Outcome(data, {}, status, message)


KIND = AnalysisKind("peak", Peak, check, seconds, run_peak, pictures.peak, plan=plan,
                    kernels=True, assembly=True, notes=True)
