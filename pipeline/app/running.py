"""What every analysis of a run shares: the :class:`Run` (results writer, folder, progress,
models, curve store, executor) and the one loop that runs independent curves as tasks,
keeping what finishes (:func:`execute`, :func:`computed_curves`), with the helpers the
analyses' runners have in common (outputs, progress ticks, cached curves, pictures, the
worst status of several)."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from microslip.case import Case, lumped_model
from microslip.case.specs import Analysis
from microslip.results import schema
from microslip.results.writer import ResultsWriter, set_attrs

from .models import AssemblyModels, LumpedModels
from .progress import time_left
from .store import CurveStore, draw_once
from .tasks import Distributed, Outcome, Progress, Serial, Task


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


def execute(run: Run, tasks: list[Task], what: str,
            keep: Callable[[int, Outcome], None], count: bool = True) -> bool:
    """Run ``tasks`` on the run's executor, ``keep(task index, outcome)`` as each finishes
    (writing, saving and saying what it brought: the caller's); an interrupted outcome
    ends the loop after it is kept. Whether the user interrupted while a cluster worked
    (Ctrl-C: the outstanding tasks are cancelled), the one place that handles it."""
    try:
        for i, outcome in run.executor.run(tasks, run.models, run.progress, what,
                                           count=count):
            keep(i, outcome)
            if outcome.status == "interrupted":
                break
    except KeyboardInterrupt:
        return True
    return False


@dataclass(frozen=True)
class StoredRows:
    """How a study's rows went (:func:`stored_rows`): why it stopped ("" if it did not)
    and how many rows were not in the store (to compute)."""

    stopped: str
    to_compute: int


def stored_rows(run: Run, name: str, keys: list[str], task: Callable[[int], Task],
                fill: Callable[[int, dict], None], announce: Callable[[int, int], str],
                line: Callable[[int, Outcome, str], str]) -> StoredRows:
    """A study's rows (an uncertainty sample, a mistuning pattern), each from the store
    under ``keys[i]`` or computed by ``task(i)`` (a task each, on the run's executor) and
    stored once complete or stopped; ``fill(i, row)`` takes each in. ``announce(cached,
    to_compute)`` is the line before; ``line(i, outcome, count)`` each computed row's
    (``count``: "k of n computed" with the time left)."""
    tasks, slots = [], []
    for i, key in enumerate(keys):
        row = run.store.load_row(key)
        if row is None:
            tasks.append(task(i))
            slots.append((i, key))
        else:
            fill(i, row)
    run.progress(announce(len(keys) - len(tasks), len(tasks)))
    stopped, computed, t = "", 0, time.perf_counter()

    def keep(j: int, outcome: Outcome) -> None:
        nonlocal stopped, computed
        i, key = slots[j]
        if outcome.status == "interrupted":
            stopped = outcome.message
            return
        row = dict(outcome.data) | {"status": outcome.status, "message": outcome.message,
                                    "seconds": outcome.seconds}
        fill(i, row)
        if outcome.status in ("complete", "stopped"):
            run.store.save_row(key, row)
        computed += 1
        left = time_left(time.perf_counter() - t, computed / len(tasks))
        for text in outcome.lines:
            run.progress(text)
        run.progress(line(i, outcome, f"{computed} of {len(tasks)} computed"
                          + (f", {left}" if left else "")))

    if execute(run, tasks, f"[{name}] ", keep, count=False):
        stopped = "interrupted by the user"
    return StoredRows(stopped, len(tasks))


def rows_status(stored: StoredRows, status: np.ndarray, messages: list[str], noun: str,
                what: Callable[[int], str]) -> tuple[str, str]:
    """(status, message) of a study from its rows' statuses: interrupted, complete, failed
    (every row failed) or stopped, naming the first row not complete (``what(i)``)."""
    if stored.stopped:
        return "interrupted", stored.stopped
    bad = [(i, status[i], messages[i]) for i in range(len(status)) if status[i] != "complete"]
    if not bad:
        return "complete", ""
    i, s, m = bad[0]
    failed = len(bad) == len(status) and all(x == "failed" for _, x, _ in bad)
    return ("failed" if failed else "stopped"), (
        f"{len(bad)} of {len(status)} {noun} not complete (the statistics leave them out); "
        f"{what(i)}: {s} {m}".rstrip())


def computed_curves(run: Run, group: h5py.Group, tasks: list[Task],
                    targets: list[tuple[int, str, str]], what: str
                    ) -> dict[int, tuple[str, str]]:
    """Run the curves' ``tasks`` (``targets``: each one's (index, store key, group name)),
    writing each into ``group`` as it finishes and keeping the finished ones (complete, or
    stopped for a reason a re-run would meet again) in the store; {index: (status,
    message)}. An interrupt (an interrupted curve, or Ctrl-C while a cluster works) ends it:
    then index -1 holds the interruption."""
    out: dict[int, tuple[str, str]] = {}

    def keep(i: int, outcome: Outcome) -> None:
        j, key, curve = targets[i]
        if outcome.data:  # a task that failed on a worker brought nothing
            warned = [line for line in outcome.lines if line.startswith("warning:")]
            attrs = outcome.attrs | ({"warnings": json.dumps(warned)} if warned else {})
            run.writer.write_group(group, curve, outcome.data, attrs)
            run.writer.flush()
        out[j] = (outcome.status, outcome.message)
        if outcome.status in ("complete", "stopped"):
            run.store.save(key, group[curve])
        for line in outcome.lines:
            run.progress(line)

    if execute(run, tasks, what, keep):
        out[-1] = ("interrupted", "interrupted by the user")
    return out


def outputs(case: Case, names: tuple[str, ...] | None, models=None
             ) -> tuple[list[str], object]:
    """(output names, their selection: DOF indices or rows of the shared DOFs); ``names``
    None: every output of the case."""
    models = models or LumpedModels()
    names = models.expanded(case, list(names)) if names is not None else models.names(case)
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


def cached_curve(store: CurveStore, key: str, group, curve: str, what: str,
                  progress: Progress, identity: dict) -> tuple[str, str] | None:
    """(status, message) of the curve ``group[curve]`` copied from the store, saying so
    (``what`` formats its number of points: the length of its ``omega``, which every
    curve of the store has, an FRF's, a peak curve's, a backbone's); None when the store
    does not have it.

    The store is keyed by what a curve computes, so another analysis (or another family
    member) may have computed it: its ``identity`` attributes (label, family key and value)
    are this analysis' own, set over the stored ones."""
    if not store.load(key, group, curve):
        return None
    g = group[curve]
    set_attrs(g, identity)
    status, message = str(g.attrs["status"]), str(g.attrs["message"])
    progress(f"{what.format(g['omega'].shape[0])}, {status}, from the cache "
             f"(computed in {g.attrs['elapsed_s']:.1f} s) {message}".rstrip())
    return status, message


def member_identity(spec: Analysis, label: str, value) -> dict:
    """The attributes that say which member of an analysis a curve is (not what it
    computes): its label, family key and value ("" without a family)."""
    family = getattr(spec, "family", None)
    return {"label": label, "family_key": family.key if family else "",
            "family_value": value if value is not None else ""}


def draw_analysis(draw, group: h5py.Group, spec: Analysis, run: Run, keys: list[str] = (),
          cached: bool = False) -> None:
    draw_once(draw, group, spec, run.out, run.progress, keys, cached)


def worst(statuses: list[tuple[str, str]]) -> tuple[str, str]:
    for key in ("interrupted", "stopped", "failed"):
        for s, m in statuses:
            if s == key:
                return s, m
    return "complete", ""


def interrupted(statuses: list[tuple[str, str]]) -> bool:
    return any(s == "interrupted" for s, _ in statuses)


def floquet(points: list) -> np.ndarray:
    """(n, schema.FLOQUET) the leading exponents of each point's Stability (NaN: fewer, or
    no stability there)."""
    out = np.full((len(points), schema.FLOQUET), np.nan + 0j)
    for i, s in enumerate(points):
        if s is not None:
            k = min(s.exponents.size, schema.FLOQUET)
            out[i, :k] = s.exponents[:k]
    return out


def attr_list(values: list[str]) -> str:
    return json.dumps(list(values))


def time_model(case: Case, spec: Analysis):
    """(case as set, HB model, output names, indices, time model, load steps) of a time
    integration of the lumped case (``solve.dti``)."""
    from microslip.solve import dti

    c = case.with_values(spec.set)
    hb = lumped_model(c)
    names, idx = outputs(c, spec.outputs)
    tm = dti.TimeModel.from_harmonic_balance(hb)
    loads = dti.LoadSteps.from_excitation(
        hb.excitation, hb.linear.n_dof, ramp_time=spec.ramp_time,
        settle_time=spec.settle_time, ramp_periods=spec.ramp_periods)
    return c, hb, names, idx, tm, loads
