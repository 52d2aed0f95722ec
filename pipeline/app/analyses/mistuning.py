"""``type = "mistuning"``: how much the worst blade's resonance grows over random mistuning
patterns, with the friction dampers and without them (issue 43).

A case with ``[assembly.mistuning]`` (its blade region) runs, per standard deviation
``sigma`` and pattern, the whole disk with blade s's Young's modulus times ``1 + sigma z_s``.
z is the standard-normal vector of pattern j, drawn from ``seed`` and j alone: every sigma
level sees the same z (common random numbers: the curve against sigma is smooth per
pattern), and a study grown from 16 to 64 patterns computes the 48 new ones only (each
pattern a task, kept in the store). The tuned disk is one more task: the cyclic sector at
the same force.

Per pattern: the window swept (upwards, then downwards where that stops, as the
uncertainty study's samples), each blade's largest response over the computed points, the
worst blade's peak refined, and the amplification A = that peak / the tuned peak. With
``free``, the same for the disk without its dampers (linear, solved directly: the classic
mistuned blisk, bounded by Whitehead's (1 + sqrt N) / 2).

A ``family`` (the dampers' mass or friction coefficient, say) repeats the study per member:
its own tuned disk and the same patterns, drawn in one picture.
"""

from __future__ import annotations

import copy
import json
import time
from dataclasses import dataclass
from typing import Any, ClassVar

import h5py
import numpy as np

from microslip.case import Case, curve_variants, operating_point, settings, task_seconds
from microslip.case import analysis_rules as rules
from microslip.case.checks import is_int, is_number, number
from microslip.case.estimate import balance_point_seconds
from microslip.case.kinds import AnalysisKind, Checking
from microslip.case.mistuning_table import MAX_SIGMA
from microslip.case.specs import Analysis, Family
from microslip.draw import pictures
from microslip.results import schema
from microslip.solve.sampling import exceedance, exceedance_text, window_edge_text

from ..limits import linear_peak
from ..models import AssemblyModels
from ..plan import PlanContext, Stage, samples_stage
from ..running import Run, draw_analysis, member_identity, rows_status, stored_rows
from ..solutions import refined_peak, response_at
from ..tasks import Outcome, Progress, Task
from .uncertainty import swept_window

#: the percentiles of the amplification reported per sigma level
PERCENTS = (5.0, 50.0, 95.0)
#: the largest number of patterns per level
MAX_PATTERNS = 100_000
#: Newton solves of a pattern per method: its sweep and the worst blade's refined peak (the
#: shipped 48-blade case at 1 N by arclength: 31 points at sigma 0.25 %, 63 at 5 % over a
#: window the mistuned family spans, and ~12 trials; a generic curve's CURVE_POINTS +
#: PEAK_SOLVES = 100 said 510 s a pattern against 140-240 s measured. Its friction study
#: (mu 0.1, 3 N) swept downwards: 186-244 natural solves, 839 s with its tuned disk, 297 s
#: since the dampers are eliminated first in the preconditioner and Newton is inexact;
#: ~1e3 s said, an upper bound where a pattern's folds cost detours: up to ~30 min)
PATTERN_SOLVES = {"arclength": 60, "natural": 200, "natural-down": 200}
#: a pattern's continuation: ``arclength`` follows every fold of the branch (where the
#: dampers slip and lift off, the small folds and kinks of each sector's flanks one after
#: another: hours a 48-blade pattern at 10 N); ``natural`` steps the frequency upwards and
#: jumps at a fold as a slow sine sweep does, ``natural-down`` downwards. Friction and
#: lift-off soften a resonance (its peak leans to lower frequencies, over a fold): a sweep
#: downwards climbs the upper branch to the peak and jumps down after it, one upwards jumps
#: onto it past the peak, which it misses
METHODS = ("arclength", "natural", "natural-down")


@dataclass(frozen=True, kw_only=True)
class MistuningStudy(Analysis):
    """The worst blade's peak of ``output`` over the frequency ``window`` (rad/s) for
    ``patterns`` random mistuning patterns at each standard deviation in ``sigma``
    (fractions of the blades' Young's modulus), ``seed``ed; ``free``: the disk without its
    dampers too (linear); ``limit``: the amplification whose exceedance probability is
    reported per level; ``family``: the study once per member; ``method``: each window's
    continuation (see METHODS)."""

    type: ClassVar[str] = "mistuning"
    window: tuple[float, float]
    output: str
    sigma: tuple[float, ...]
    patterns: int = 16
    seed: int = 0
    measure: str = "vibration"
    free: bool = True
    limit: float | None = None
    family: Family | None = None
    method: str = "arclength"

    def draws(self, sectors: int) -> np.ndarray:
        """(patterns, sectors) z: pattern j's standard-normal draw, from (seed, j) alone."""
        return np.array([np.random.default_rng([self.seed, j]).standard_normal(sectors)
                         for j in range(self.patterns)])


#: The numbers of a pattern's row (NaN where not found)
ROW = ("peak", "omega", "blade", "free_peak", "free_omega", "points", "samples")


def pattern_task(models: AssemblyModels, c: Case, spec: MistuningStudy,
                 *, progress: Progress, live: bool = True) -> Outcome:
    """One pattern's worst blade (the variant ``c``, a whole disk), or the tuned disk's
    peak (``c`` the cyclic sector): a task."""
    names = models.expanded(c, [spec.output])
    rows = models.selection(c, names)
    base = operating_point(c, spec.window[0])
    solver = settings(c)
    disk = isinstance(c.data["assembly"].get("mistuning"), dict)
    downwards = spec.method.endswith("-down")  # the first sweep starts at the top
    first = operating_point(c, spec.window[1]) if downwards else base
    start = _tuned_start(models, c, first, solver) if disk else None
    swept = swept_window(models.model(c), spec.window, base, solver, start, spec.method)
    if swept.interrupted:
        return Outcome({}, {}, "interrupted", "interrupted by the user")
    data: dict[str, Any] = dict.fromkeys(ROW, np.nan) | {"points": 0,
                                                        "samples": swept.samples}
    if spec.free:
        w, a = linear_peak(models.assembly(c), base, "free", names, spec.window,
                           spec.measure == "vibration")
        data |= {"free_peak": a, "free_omega": w}
    if not swept.found:
        return Outcome(data, {}, "failed", swept.message or "no solution in the window")
    shown = [np.array([response_at(r.model, x, r.point(i), rows, spec.measure)
                       for i, x in enumerate(r.branch.x)]) for r in swept.found]
    blade_peaks = np.max([y.max(axis=0) for y in shown], axis=0)
    blade = int(np.argmax(blade_peaks))
    top = int(np.argmax([y[:, blade].max() for y in shown]))
    w, x = refined_peak(swept.found[top], shown[top][:, blade], rows[blade:blade + 1],
                        spec.measure, solver)
    peak = float(response_at(swept.found[top].model, x, base.set("frequency", w),
                             rows[blade:blade + 1], spec.measure)[0])
    blade_peaks[blade] = max(blade_peaks[blade], peak)
    data |= {"peak": peak, "omega": w, "blade": blade, "blade_peaks": blade_peaks,
             "points": sum(len(r) for r in swept.found)}
    return Outcome(data, {}, swept.status, swept.message)


def _tuned_start(models: AssemblyModels, c: Case, point, solver) -> np.ndarray | None:
    """A pattern's start at the window's: the tuned sector's solution there turned onto
    every sector (the travelling wave), None where the sector does not converge."""
    from microslip.assembly.mistuned import travelling_wave
    from microslip.geometry.full_disk import disk_node_map
    from microslip.solve.response import solve_point

    sector = models.assembly(_sector(c))
    r = solve_point(sector.hb, point, settings=solver)
    if not r.converged:
        return None
    try:  # (a guess only: where the sector's nodes do not all map, the cold start)
        return travelling_wave(sector, models.assembly(c), r.x, point,
                               disk_node_map(models.mesh))
    except (KeyError, IndexError, ValueError):
        return None


@dataclass(frozen=True)
class Member:
    """The study of one family member (the whole study without a family): its ``label``
    and family ``value``, the ``tuned`` sector, (sigma, deviations) per pattern level by
    level (``pairs``) and their whole ``disks``."""

    label: str
    value: Any
    tuned: Case
    pairs: list[tuple[float, np.ndarray]]
    disks: list[Case]

    @property
    def cases(self) -> list[Case]:
        """The tuned sector, then the patterns' disks: a task each."""
        return [self.tuned, *self.disks]


def members(case: Case, spec: MistuningStudy) -> list[Member]:
    """A Member per family value (one without a family): the case's ``set`` and member
    keys applied, its blade region kept, its own pattern replaced by the study's."""
    counts: dict[str, int | None] = {}  # blades per geometry (an import read once)
    out = []
    for variant, label, value in curve_variants(case, spec):
        geometry = json.dumps(variant.data.get("geometry"), sort_keys=True, default=str)
        if geometry not in counts:
            counts[geometry] = _sectors(variant)
        out.append(_member(variant, spec, label, value, counts[geometry]))
    return out


def _member(base: Case, spec: MistuningStudy, label: str, value: Any, sectors: int | None
            ) -> Member:
    table = dict(base.data["assembly"]["mistuning"])
    region = {k: table[k] for k in ("body", "blade_radius", "region") if k in table}
    if sectors is None:
        raise ValueError("mistuning study: the sector count is unknown before meshing")
    z = spec.draws(sectors)
    pairs = [(s, s * z[j]) for s in spec.sigma for j in range(spec.patterns)]
    disks = [base.with_values({"assembly.mistuning": region | {"deviation": d.tolist()}})
             for _, d in pairs]
    return Member(label, value, _sector(base), pairs, disks)


def _sector(case: Case) -> Case:
    """The case as the cyclic sector (its [assembly.mistuning] left out): the tuned disk at
    the same force, N times smaller. Its tables are the validated case's; its analyses,
    which need the whole disk, are left out."""
    data = copy.deepcopy(case.data)
    del data["assembly"]["mistuning"]
    data["analysis"] = []
    return Case(data, case.source, case.renamed, case.kinds)


def _sectors(case: Case) -> int | None:
    """The blades of a case: its geometry's ``sectors`` parameter, or its imported mesh's."""
    params = case.data.get("geometry", {}).get("parameters", {})
    if is_int(params.get("sectors")):
        return int(params["sectors"])
    if case.geometry_table.imported:
        from microslip.geometry.full_disk import sector_count

        return sector_count(case.geometry_table.build())
    return None


def pattern_key(store, variant: Case, spec: MistuningStudy) -> str:
    """The store key of a pattern or of the tuned disk: its variant and the window, output,
    measure, ``free`` and ``method`` (not sigma, the count or the seed: the variant holds
    the pattern)."""
    return store.key(variant.data, {"type": spec.type, "window": list(spec.window),
                                    "output": spec.output, "measure": spec.measure,
                                    "free": spec.free, "method": spec.method},
                     curve="pattern")


def run_mistuning(case: Case, spec: MistuningStudy, group: h5py.Group, run: Run
                  ) -> tuple[str, str]:
    """Every member's tuned disk and patterns (a task each, or from the store), their
    table, the amplification's statistics per level and the pictures."""
    name, store = spec.name, run.store
    t0 = time.perf_counter()
    _free_faults(case, spec, run.models)
    study = members(case, spec)
    cases = [c for m in study for c in m.cases]
    first = np.cumsum([0] + [len(m.cases) for m in study])  # each member's tuned disk
    found: list[dict] = [{} for _ in cases]  # each task's row ({}: not run)
    keys = [pattern_key(store, v, spec) for v in cases]
    each = task_seconds(case.data, spec)

    def what(i: int) -> str:
        m, k = locate(first, i)
        which = "the tuned disk" if k == 0 else f"pattern {k} of {len(study[m].pairs)}"
        return f"{study[m].label}: {which}" if study[m].label else which

    def fill(i: int, row: dict) -> None:
        found[i] = row

    def line(i: int, outcome: Outcome, count: str) -> str:
        r = found[i]
        return (f"[{name}] {what(i)} ({count}): peak {r.get('peak', np.nan):.4g} m at "
                f"{r.get('omega', np.nan):.6g} rad/s {outcome.status} "
                f"{outcome.message}".rstrip())

    patterns = len(study[0].pairs)
    rows = stored_rows(
        run, name, keys,
        lambda i: Task(pattern_task, (cases[i], spec), f"[{name}] {what(i)}", each), fill,
        lambda cached, todo: (
            f"[{name}] the tuned disk and {patterns} patterns ({len(spec.sigma)} "
            f"level{'s' if len(spec.sigma) > 1 else ''} x {spec.patterns}, seed {spec.seed}) "
            f"of {len(study[0].pairs[0][1])} blades"
            + (f", for each of {len(study)} members" if spec.family else "")
            + f": {cached} from the cache, {todo} to compute"), line)
    summary = []
    for m, member in enumerate(study):
        here = group
        if spec.family:
            run.writer.write_group(group, schema.curve(m), {},
                                   member_identity(spec, member.label, member.value))
            here = group[schema.curve(m)]
        tables = _table(found[first[m]:first[m + 1]], len(member.pairs[0][1]))
        levels = _write(run.writer, here, spec, member.pairs, tables)
        summary += _summary(spec, member.label, levels, tables, len(member.pairs[0][1]))
    run.progress("\n".join([f"[{name}] {len(cases) - len(study)} patterns in "
                            f"{time.perf_counter() - t0:.1f} s", *summary]))
    draw_analysis(pictures.mistuning, group, spec, run, keys, cached=not rows.to_compute)
    status = np.array([r.get("status", "not run") for r in found], dtype=object)
    return rows_status(rows, status, [str(r.get("message", "")) for r in found], "runs", what)


def _free_faults(case: Case, spec: MistuningStudy, models: AssemblyModels) -> None:
    """InputError where ``free`` asks the disk without its contacts of a study whose
    mistuned body is separate blades (the root joint's): that disk is the cyclic bodies
    alone, without those blades, so its peak says nothing of theirs."""
    from microslip.case import InputError
    from microslip.case.mistuning_table import MistuningTable

    mesh = models.mesh
    table = MistuningTable.of(case.with_values(spec.set).data["assembly"]["mistuning"])
    body = table.body_of(tuple(mesh.cyclic), tuple(mesh.bodies))
    if spec.free and body not in mesh.cyclic:
        raise InputError(f"analysis.{spec.name}.free = true: the disk without its contacts "
                         f"is its cyclic bodies alone, without the separate blades {body!r} "
                         "the study mistunes: set free = false")


def locate(first: np.ndarray, i: int) -> tuple[int, int]:
    """(member, k) of the study's task ``i``, the members' tasks one after another from
    ``first`` (each member's first, then the end): k 0 its tuned disk, k its pattern k."""
    m = int(np.searchsorted(first, i, side="right")) - 1
    return m, i - int(first[m])


def whitehead(sectors: int) -> float:
    """Whitehead's bound on the linear mistuned disk's amplification, (1 + sqrt N) / 2."""
    return (1 + np.sqrt(sectors)) / 2


def _table(found: list[dict], sectors: int) -> dict[str, np.ndarray]:
    """One member's rows (its tuned disk first) as columns: ROW, seconds and status (NaN,
    0 and "not run" where a task did not run), and the patterns' blade_peaks (n, N)."""
    out = {k: np.array([r.get(k, np.nan) for r in found], dtype=float) for k in ROW}
    out["seconds"] = np.array([r.get("seconds", 0.0) for r in found], dtype=float)
    out["status"] = np.array([str(r.get("status", "not run")) for r in found], dtype=object)
    out["blade_peaks"] = np.array([r.get("blade_peaks", np.full(sectors, np.nan))
                                   for r in found[1:]], dtype=float).reshape(-1, sectors)
    return out


def amplification_levels(sigma: np.ndarray, amplification: np.ndarray, ok: np.ndarray,
                         levels: tuple[float, ...], limit: float | None = None
                         ) -> dict[str, np.ndarray]:
    """Per level: the percentiles (PERCENTS), the largest, the mean, the count and
    P(amplification > limit) with its standard error, of its complete patterns (NaN where
    it has none, or without a limit)."""
    nan = np.full(len(levels), np.nan)
    out = {"percentiles": np.full((len(levels), len(PERCENTS)), np.nan),
           "largest": nan.copy(), "mean": nan.copy(),
           "count": np.zeros(len(levels), dtype=np.int64), "exceedance": nan.copy(),
           "exceedance_error": nan.copy()}
    for k, s in enumerate(levels):
        a = amplification[(sigma == s) & ok & np.isfinite(amplification)]
        out["count"][k] = a.size
        out["exceedance"][k], out["exceedance_error"][k] = exceedance(a, limit)
        if a.size:
            out["percentiles"][k] = np.percentile(a, PERCENTS)
            out["largest"][k], out["mean"][k] = a.max(), a.mean()
    return out


def _write(writer, group, spec: MistuningStudy, pairs, table: dict[str, np.ndarray]
           ) -> dict[str, dict[str, np.ndarray]]:
    """One member's patterns' table and its amplification per level, with friction and
    free, into ``group`` (the analysis', or its member's)."""
    sigma = np.array([s for s, _ in pairs])
    deviation = np.array([d for _, d in pairs])
    sectors = deviation.shape[1]
    tuned = {k: table[k][0] for k in ("peak", "omega", "free_peak", "free_omega")}
    status = table["status"]
    rows = {k: table[k][1:] for k in (*ROW, "seconds")}
    ok = status[1:] == "complete"
    amp = rows["peak"] / tuned["peak"]
    free_amp = rows["free_peak"] / tuned["free_peak"]
    writer.write_group(group, schema.PATTERNS, {
        "sigma": sigma, "deviation": deviation, "blade_peaks": table["blade_peaks"], **rows,
        "amplification": amp, "free_amplification": free_amp,
        "status": np.array(status[1:].tolist(), dtype="S")}, {
        "seed": spec.seed, "sectors": sectors, "tuned_status": str(status[0]),
        **{f"tuned_{k}": float(v) for k, v in tuned.items()}})
    levels = {"friction": amplification_levels(sigma, amp, ok, spec.sigma, spec.limit)}
    if spec.free:
        levels["free"] = amplification_levels(sigma, free_amp, ok, spec.sigma, spec.limit)
    writer.write_group(group, schema.AMPLIFICATION, {
        "sigma": np.array(spec.sigma), **{f"{k}_{x}": v for k, d in levels.items()
                                          for x, v in d.items()}}, {
        "percent": list(PERCENTS), "whitehead": whitehead(sectors),
        "limit": spec.limit if spec.limit is not None else np.nan,
        "cases": json.dumps(list(levels))})
    writer.flush()
    return levels


def _summary(spec: MistuningStudy, label: str, levels: dict, table: dict, sectors: int
             ) -> list[str]:
    """The terminal's lines of one member: its tuned peak (and without the dampers) and
    Whitehead's bound, then per level and case the amplification's median, 95 %, largest
    and P(A > limit), and the peaks at an end of the window (lower bounds) where any."""
    pre = f"[{spec.name}] " + (f"{label}: " if label else "")
    lines = [pre + f"tuned peak {table['peak'][0]:.4g} m at {table['omega'][0]:.6g} rad/s"
             + (f", free {table['free_peak'][0]:.4g} m" if spec.free else "")
             + f"; Whitehead's bound {whitehead(sectors):.3f}"]
    for k, s in enumerate(spec.sigma):
        for case, d in levels.items():
            p5, p50, p95 = d["percentiles"][k]
            over = (f", P(A > {spec.limit:g}) " + exceedance_text(
                d["exceedance"][k], d["exceedance_error"][k], d["count"][k])
                if spec.limit is not None else "")
            lines.append(f"{pre}  sigma {s:g}, {case}: amplification median {p50:.3f}, "
                         f"95 % {p95:.3f}, largest {d['largest'][k]:.3f}{over} "
                         f"({d['count'][k]} patterns)")
    names = ["the tuned disk"] + [f"sigma {s:g} pattern {j + 1}" for s in spec.sigma
                                  for j in range(spec.patterns)]
    complete = table["status"] == "complete"
    complete[0] = True  # (the tuned disk: its peak divides every amplification)
    for case, key in (("friction", "omega"), ("free", "free_omega")):
        omega = np.where(complete, table[key], np.nan)  # (as the statistics: complete ones)
        edge = window_edge_text(omega, spec.window, names) if case in levels else ""
        lines += [f"{pre}  {case}: {edge}"] if edge else []
    return lines


def check(c: Checking) -> None:
    """A study's own rules: its window, output, levels, counts, and a case that is a
    mistuned whole disk (its [assembly.mistuning] gives the blade region)."""
    a = c.table
    rules.window_faults(c)
    rules.output_fault(c, "output")
    sig = a.get("sigma")
    if not (isinstance(sig, list) and sig and all(is_number(s) and 0 < s <= MAX_SIGMA
                                                  for s in sig)):
        c.fault(f".sigma = {sig!r}: expected a list of standard deviations in (0, "
                f"{MAX_SIGMA}] (fractions of the blades' Young's modulus)")
    if not (is_int(a["patterns"]) and 1 <= a["patterns"] <= MAX_PATTERNS):
        c.fault(f".patterns = {a['patterns']!r}: expected an integer from 1 to {MAX_PATTERNS}")
    if not (is_int(a["seed"]) and a["seed"] >= 0):
        c.fault(f".seed = {a['seed']!r}: expected an integer >= 0")
    rules.measure_faults(c, ("peak", "vibration"))
    rules.family_faults(c)
    family = a.get("family") if isinstance(a.get("family"), dict) else {}
    touched = [str(family.get("key", ""))] + [k for t in family.get("sets") or ()
                                              if isinstance(t, dict) for k in t]
    if any(k.startswith("assembly.mistuning") for k in touched):
        c.fault(".family: varies [assembly.mistuning], which the study draws itself (vary "
                "sigma, or the dampers' keys)")
    if a.get("limit") is not None:
        number(f"{c.pre}.limit", a["limit"], c.out, positive=True)
    rules.flag(c, "free", " (the disk without its dampers too)")
    if a.get("method") not in METHODS:
        c.fault(f".method = {a.get('method')!r}: expected one of {list(METHODS)}")
    if not isinstance((c.data.get("assembly") or {}).get("mistuning"), dict):
        c.fault(": needs [assembly.mistuning] (its blades: a cyclic body's blade_radius or "
                "region, or a body of separate blades; the study draws the deviations)")


def seconds(data: dict, spec: MistuningStudy, variant: dict | None = None) -> float:
    """One pattern: PATTERN_SOLVES Newton solves of the whole disk (its method's)."""
    return PATTERN_SOLVES[spec.method] * balance_point_seconds(data, spec, variant)


def plan(case: Case, spec: MistuningStudy, context: PlanContext) -> list[Stage]:
    """Every member's tuned disk and patterns as one stage: those the store does not
    have."""
    keys = [pattern_key(context.store, v, spec) for m in members(case, spec)
            for v in m.cases]
    return [samples_stage(case, spec, context, keys, "tasks (tuned disks and patterns)")]


KIND = AnalysisKind("mistuning", MistuningStudy, check, seconds, run_mistuning,
                    pictures.mistuning, plan=plan, kernels=True, lumped=False, assembly=True)
