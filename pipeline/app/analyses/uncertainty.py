"""The uncertainty study (``type = "uncertainty"``): the spread of a resonance peak when
parameters are uncertain.

Each sample of the design (``solve.sampling``) is a case variant and a task: an
arclength sweep over the window, its top refined (the FRF maps' refined peak), the peak's
frequency and the share of contact points slipping there. Samples whose inputs did not
change come from the store (a Sobol' study grown from 64 to 256 samples computes the 192
new ones). The client writes the samples as one table, their statistics and, for an
assembly case, the free and fully stuck peaks at the case's own values; then the pictures.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import h5py
import numpy as np

from microslip.case import Case, operating_point, settings, task_seconds
from microslip.case import analysis_rules as rules
from microslip.case.build import sample_variants
from microslip.case.estimate import CURVE_POINTS, PEAK_SOLVES, balance_point_seconds
from microslip.case.kinds import AnalysisKind, Checking
from microslip.case.specs import Analysis, distribution
from microslip.draw import pictures
from microslip.laws.coulomb import slip_share
from microslip.results import schema
from microslip.solve.response import sweep, undersampled_points
from microslip.solve.sampling import (
    PERCENTILES,
    Distribution,
    design,
    exceedance_text,
    statistics,
    window_edge_text,
)

from ..limits import linear_peak
from ..models import AssemblyModels, LumpedModels
from ..plan import PlanContext, Stage, samples_stage
from ..running import Run, draw_analysis, rows_status, stored_rows
from ..solutions import refined_peak, response_at
from ..tasks import Outcome, Progress, Task


@dataclass(frozen=True, kw_only=True)
class Uncertainty(Analysis):
    """The spread of a resonance peak under uncertain ``parameters``: per sample, the
    largest ``measure`` of ``output`` over the frequency ``window`` (rad/s; an arclength
    sweep, its top refined), its frequency and the share of contact points slipping there.

    ``parameters``: name -> a distribution table (``{uniform = [low, high]}``,
    ``{normal = {mean, sigma}}``, ``{lognormal = {median, sigma}}``) or a fixed value; a
    dotted name is a case key, a plain one that key of every contact (``mu``). ``samples``
    of a seeded ``design`` (``solve.sampling.DESIGNS``); ``limit``: the peak whose
    exceedance probability is reported (m); ``levels``: the free and fully stuck peaks
    at the case's own values (an assembly case)."""

    type: ClassVar[str] = "uncertainty"
    window: tuple[float, float]
    output: str
    parameters: Mapping[str, Any]
    samples: int = 64
    design: str = "sobol"
    seed: int = 0
    measure: str = "peak"
    limit: float | None = None
    levels: bool = False

    def distributions(self) -> list[tuple[str, Distribution]]:
        """(name, distribution) of each uncertain parameter, in the case's order."""
        return [(k, distribution(v)) for k, v in self.parameters.items()
                if isinstance(v, Mapping)]

    def fixed(self) -> dict[str, float]:
        """The parameters held at a value."""
        return {k: v for k, v in self.parameters.items() if not isinstance(v, Mapping)}

    def sample_values(self) -> tuple[list[str], np.ndarray]:
        """(names, (samples, p) values) of the uncertain parameters."""
        pairs = self.distributions()
        x = design([d for _, d in pairs], self.samples, self.design, self.seed)
        return [k for k, _ in pairs], x


#: The numbers of a sample (its row of the samples table), NaN where not found; samples:
#: per period, of the sweeps that gave it.
ROW = ("peak", "omega", "slip_share", "points", "samples")

#: A sweep crawls where its last CRAWL_POINTS points moved the frequency by less than
#: CRAWL_SPAN of the window. With stick arcs within two samples there, the sampled forces
#: change in steps between kinks and the steps stay short for minutes (4-26 of the 42 of
#: blisk_uncertainty's 64 samples): the sweep goes on at twice the samples from there.
CRAWL_POINTS = 20
CRAWL_SPAN = 1e-4


class UnderResolved:
    """The ``watch`` of a sweep (:func:`continuation.arclength`): its message where the
    sweep crawls (CRAWL_POINTS, CRAWL_SPAN of ``span``) and ``undersampled(lam, x)``, the
    contact points with a stick arc within two samples there, is not zero; else ""."""

    def __init__(self, undersampled: Callable[[float, np.ndarray], int], span: float) -> None:
        self.undersampled = undersampled
        self.span = span
        self.recent: list[float] = []  # the last CRAWL_POINTS points' frequencies

    def __call__(self, lam: float, x: np.ndarray) -> str:
        self.recent = [*self.recent[1 - CRAWL_POINTS:], lam]
        if (len(self.recent) < CRAWL_POINTS
                or max(self.recent) - min(self.recent) >= CRAWL_SPAN * self.span):
            return ""
        n = self.undersampled(lam, x)
        if not n:
            return ""
        return (f"crawling at {lam:.6g} rad/s (the last {CRAWL_POINTS} points within "
                f"{CRAWL_SPAN:g} of the window) with stick arcs within two samples at {n} "
                "contact point(s)")


def _undersampled(model, base) -> Callable[[float, np.ndarray], int]:
    """(lam, x) -> the contact points of ``model`` with a stick arc within two samples."""
    return lambda lam, x: undersampled_points(model, x, base.set("frequency", lam))


def sample_task(models: LumpedModels | AssemblyModels, c: Case, spec: Uncertainty, index: int,
                *, progress: Progress, live: bool = True) -> Outcome:
    """The peak of one sample (the case variant ``c``): a task (``tasks``). The window is
    swept upwards; where that sweep stops short it is swept downwards from its top too,
    and the two together must cover it (a crawl or a turn the upward sweep could not follow,
    e.g. where a contact with a gap closes, is often passed from the other side). Where
    they do not, each sweep goes on from where it stopped with the period sampled twice as
    finely: what stops them is nearly always a stick/slip kink that falls between samples
    (the peak moves by < 0.03 % on the blisk, a crawl becomes a smooth branch), and what
    they found is kept, not computed again. A sweep that crawls with stick arcs within two
    samples is stopped there (UnderResolved), not left to crawl for minutes. The peak is the
    largest response of the branches (each at its own sampling), refined."""
    hb = models.model(c)
    rows = models.selection(c, [spec.output])
    base = operating_point(c, spec.window[0])
    solver = settings(c)
    swept = swept_window(hb, spec.window, base, solver)
    if swept.interrupted:
        return Outcome({}, {}, "interrupted", "interrupted by the user")
    found, status, message, samples = swept.found, swept.status, swept.message, swept.samples
    if not found:
        return Outcome(dict.fromkeys(ROW, np.nan) | {"points": 0, "samples": samples}, {},
                       "failed", message or "no solution in the window")
    shown = [np.array([response_at(r.model, x, r.point(i), rows, spec.measure)[0]
                       for i, x in enumerate(r.branch.x)]) for r in found]
    top = int(np.argmax([np.max(y) for y in shown]))
    w, x = refined_peak(found[top], shown[top], rows, spec.measure, solver)
    model = found[top].model
    point = base.set("frequency", w)
    states = [cr.state for cr in model.contact_response(x, point)]
    share = slip_share(np.concatenate(states)) if states else np.nan
    data = {"peak": float(response_at(model, x, point, rows, spec.measure)[0]), "omega": w,
            "slip_share": share, "points": sum(len(r) for r in found), "samples": samples}
    return Outcome(data, {}, status, message)


@dataclass(frozen=True)
class WindowSweeps:
    """The branches that cover a frequency window (:func:`swept_window`): those with
    points, whether together they cover it (status, message), the finest samples per
    period they used, and whether the user interrupted them."""

    found: list
    status: str
    message: str
    samples: int
    interrupted: bool


def swept_window(hb, window: tuple[float, float], base, solver,
                 x0: np.ndarray | None = None, method: str = "arclength") -> WindowSweeps:
    """The window swept upwards (from ``x0`` where given: a guess at its start) and, where
    that stops short, downwards from its top; where the two do not cover it, each goes on
    from where it stopped at twice the samples per period (what stops them is nearly always
    a stick/slip kink between samples). ``method``: the continuation (``natural``: stepped
    in frequency, jumping at a fold as a rig's slow sine sweep does; ``natural-down``: the
    same downwards first, from ``x0`` at the window's top)."""
    up, down = _sweeps(hb, window, base, solver, _undersampled(hb, base), x0, method)
    status, message = _coverage(up, down, *window)
    notes = []
    if status == "stopped" and not _interrupted(up, down):
        notes.append(f"at {hb.harmonics.n_samples} samples per period: {message}")
        fine = hb.with_samples(2 * hb.harmonics.n_samples)
        up, down = (_resumed(fine, chain, end, base, solver, method)
                    for chain, end in ((up, window[1]), (down, window[0])))
        status, message = _coverage(up, down, *window)
    if status == "complete" and method == "natural-down" and any(r.branch.jumps for r in up):
        status = "stopped"  # (the upward sweep lands on a softened resonance past its peak)
        message += ("; where the downward sweep stopped, the upward one that covered the rest "
                    "jumped at a fold, past any peak leaning over it: not complete")
    samples = max(r.model.harmonics.n_samples for r in (*up, *down))
    return WindowSweeps([r for r in (*up, *down) if len(r)], status,
                        "; ".join([*notes, message]), samples, _interrupted(up, down))


def _sweeps(model, window: tuple[float, float], base, solver, undersampled, x0=None,
            method: str = "arclength") -> tuple[list, list]:
    """(upward, downward) sweeps of the window: the first (upwards; downwards for
    ``natural-down``) from ``x0``, the other only where the first stops; each arclength
    sweep stopped where it crawls under-resolved (UnderResolved)."""
    lo, hi = window

    def swept(start: float, stop: float, x_start: np.ndarray | None):
        watch = UnderResolved(undersampled, hi - lo) if method == "arclength" else None
        return sweep(model, "frequency", start, stop, base.set("frequency", start),
                     method=method.removesuffix("-down"), settings=solver, x0=x_start,
                     watch=watch)

    downwards = method.endswith("-down")
    first, then = ((hi, lo), (lo, hi)) if downwards else ((lo, hi), (hi, lo))
    chain = [swept(*first, x0)]
    if x0 is not None and not len(chain[0]) and chain[0].branch.status == "stopped":
        chain = [swept(*first, None)]  # a cold start
    other = [swept(*then, None)] if chain[0].branch.status == "stopped" else []
    return (other, chain) if downwards else (chain, other)


def _interrupted(*chains: list) -> bool:
    return any(r.branch.status == "interrupted" for chain in chains for r in chain)


def _resumed(model, chain: list, end: float, base, solver, method: str = "arclength"
             ) -> list:
    """``chain`` (sweeps towards ``end``) with one more by ``model`` from its last point
    where its last sweep stopped (from its start if it found nothing)."""
    if not chain or chain[-1].branch.status != "stopped":
        return chain
    last = chain[-1]
    start, x0 = ((float(last.values[-1]), last.branch.x[-1]) if len(last) else
                 (last.base.get("frequency"), None))
    return [*chain, sweep(model, "frequency", start, end, base.set("frequency", start),
                          method=method.removesuffix("-down"), settings=solver, x0=x0)]


def _coverage(up: list, down: list, lo: float, hi: float) -> tuple[str, str]:
    """(status, message) of a sample's sweeps (each chain in the order swept): complete when
    one chain reached the end of the window or the upward and downward ones overlap (said
    in the message); else the first sweep's status and why each stopped."""
    if not up or not down:
        last = (up or down)[-1].branch
        return last.status, last.message
    last_up, last_down = up[-1].branch, down[-1].branch
    reached_up = max((v for r in up for v in r.values), default=lo)
    reached_down = min((v for r in down for v in r.values), default=hi)
    if last_up.status == "complete" or last_down.status == "complete" \
            or reached_down <= reached_up:
        return "complete", (f"swept from both ends: upwards to {reached_up:.6g} rad/s "
                            f"({last_up.message}), downwards to {reached_down:.6g}")
    return "stopped", (f"upwards to {reached_up:.6g} rad/s ({last_up.message}), downwards to "
                       f"{reached_down:.6g} ({last_down.message})")


def run_uncertainty(case: Case, spec: Uncertainty, group: h5py.Group, run: Run
                    ) -> tuple[str, str]:
    """Every sample (a task each, or from the store), the samples table, its statistics,
    the linear levels (an assembly case with ``levels``) and the pictures."""
    name, store = spec.name, run.store
    t0 = time.perf_counter()
    names, x, sets = sample_variants(case, spec)
    n = len(sets)
    table = {k: np.full(n, np.nan) for k in ROW} | {"seconds": np.zeros(n)}
    status = np.array(["not run"] * n, dtype=object)
    messages = [""] * n
    each = task_seconds(case.data, spec)
    variants = [case.with_values(values) for values in sets]
    keys = [sample_key(store, v, spec) for v in variants]

    def fill(i: int, row: dict) -> None:
        _fill(table, status, messages, i, row)

    def line(i: int, outcome: Outcome, count: str) -> str:
        return (f"[{name}] sample {i + 1} of {n} ({count}): peak {table['peak'][i]:.6g} at "
                f"{table['omega'][i]:.6g} rad/s, slip share {table['slip_share'][i]:.2f} "
                f"{outcome.status} {outcome.message}".rstrip())

    rows = stored_rows(
        run, name, keys,
        lambda i: Task(sample_task, (variants[i], spec, i), f"[{name}] sample {i + 1}", each),
        fill, lambda cached, todo: (
            f"[{name}] {n} samples of {', '.join(names)} ({spec.design} design, seed "
            f"{spec.seed}): {cached} from the cache, {todo} to compute"), line)
    stopped = rows.stopped
    _write_samples(run.writer, group, spec, names, x, table, status)
    complete = status == "complete"
    st = statistics(x[complete], table["peak"][complete], spec.limit)
    levels = _levels(case, spec, run) if spec.levels and isinstance(
        run.models, AssemblyModels) and not stopped else {}
    _write_statistics(run.writer, group, spec, st, levels)
    edge = window_edge_text(np.where(complete, table["omega"], np.nan), spec.window,
                            [f"sample {i + 1}" for i in range(n)])
    run.progress(_summary(spec, names, st, levels, n, time.perf_counter() - t0, edge))
    draw_analysis(pictures.uncertainty, group, spec, run, keys, cached=not rows.to_compute)
    return rows_status(rows, status, messages, "samples", lambda i: f"sample {i + 1}")


def sample_key(store, variant: Case, spec: Uncertainty) -> str:
    """The store key of a sample: its case variant and what its numbers depend on beyond
    it, the window, output and measure (not the design, the count or the limit)."""
    return store.key(variant.data, {"type": spec.type, "window": list(spec.window),
                                    "output": spec.output, "measure": spec.measure},
                     curve="sample")


def _fill(table: dict, status: np.ndarray, messages: list, i: int, row: dict) -> None:
    for k in (*ROW, "seconds"):
        if k in row:
            table[k][i] = row[k]
    status[i] = str(row.get("status", "complete"))
    messages[i] = str(row.get("message", ""))


def _write_samples(writer, group, spec: Uncertainty, names, x, table, status) -> None:
    writer.write_group(group, schema.SAMPLES, {
        "parameters": x, **table, "status": np.array(status.tolist(), dtype="S")}, {
        "names": json.dumps(names), "design": spec.design, "seed": spec.seed,
        "distributions": json.dumps({k: spec.parameters[k] for k in names})})


def _write_statistics(writer, group, spec: Uncertainty, st, levels: dict) -> None:
    writer.write_group(group, schema.STATISTICS, {
        "percentiles": st.percentiles, "spearman": st.spearman, "prcc": st.prcc}, {
        "percent": list(PERCENTILES), "mean": st.mean, "std": st.std, "count": st.count,
        "limit": spec.limit if spec.limit is not None else np.nan,
        "exceedance": st.exceedance, "exceedance_error": st.exceedance_error,
        **levels})
    writer.flush()


def _levels(case: Case, spec: Uncertainty, run: Run) -> dict[str, float]:
    """The free and fully stuck peaks in the window at the case's own values (linear)."""
    t = time.perf_counter()
    variant = case.with_values(spec.set)
    cm = run.models.assembly(variant)
    base = operating_point(variant, spec.window[0])
    out = {}
    for springs in ("free", "stuck"):
        w, a = linear_peak(cm, base, springs, spec.output, spec.window,
                           spec.measure == "vibration")
        out |= {f"{springs}_peak": a, f"{springs}_omega": w}
    run.progress(f"[{spec.name}] free and fully stuck peaks in {time.perf_counter() - t:.1f} s")
    return out


def _summary(spec: Uncertainty, names, st, levels: dict, n: int, elapsed: float,
             edge: str = "") -> str:
    """The study's lines for the terminal: percentiles, exceedance, sensitivities, and
    ``edge``: the samples whose peak sits at an end of the window, where any."""
    p5, p50, p95 = st.percentiles
    lines = [f"[{spec.name}] peak of {spec.output} over {st.count} of {n} samples "
             f"({elapsed:.1f} s): 5 % {p5:.4g}, median {p50:.4g}, 95 % {p95:.4g} m"]
    if levels:
        lines.append(f"[{spec.name}]   free {levels['free_peak']:.4g} m, fully stuck "
                     f"{levels['stuck_peak']:.4g} m")
    if spec.limit is not None:
        lines.append(f"[{spec.name}]   P(peak > {spec.limit:g} m) " + exceedance_text(
            st.exceedance, st.exceedance_error, st.count))
    for k, rs, pr in zip(names, st.spearman, st.prcc):
        lines.append(f"[{spec.name}]   {k}: rank correlation {rs:+.2f}, partial {pr:+.2f}")
    lines += [f"[{spec.name}]   {edge}"] if edge else []
    return "\n".join(lines)


def check(c: Checking) -> None:
    """A study's own rules: its keys and distributions, the case at the extreme samples,
    its measure and flags."""
    rules.uncertainty_faults(c)
    rules.sector_only(c)
    rules.measure_faults(c, ("peak", "vibration"))
    rules.flag(c, "levels", " (the free and fully stuck peak levels, an assembly case)")


def seconds(data: dict, spec: Uncertainty, variant: dict | None = None) -> float:
    """One sample: a sweep of CURVE_POINTS points and its top refined (PEAK_SOLVES)."""
    return (CURVE_POINTS + PEAK_SOLVES) * balance_point_seconds(data, spec, variant)


def plan(case: Case, spec: Uncertainty, context: PlanContext) -> list[Stage]:
    """The samples as one stage: those the store does not have, to compute."""
    keys = [sample_key(context.store, case.with_values(v), spec)
            for v in sample_variants(case, spec)[2]]
    return [samples_stage(case, spec, context, keys)]


KIND = AnalysisKind("uncertainty", Uncertainty, check, seconds, run_uncertainty,
                    pictures.uncertainty, plan=plan, kernels=True, assembly=True)
