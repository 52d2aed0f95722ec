"""``type = "transient"``: the two load steps of a lumped case integrated in time (the static
load ramped, then the excitation grown), as time histories (Firrone & Zucca Fig. 13)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import ClassVar

import h5py

from microslip.case import Case
from microslip.case import analysis_rules as rules
from microslip.case.checks import number
from microslip.case.estimate import time_integration_seconds
from microslip.case.kinds import AnalysisKind, Checking
from microslip.draw import pictures
from microslip.results import schema
from microslip.results.writer import ATTRS

from ..running import Run, attr_list, draw_analysis, time_model
from .direct_integration import TimeIntegration, size


@dataclass(frozen=True, kw_only=True)
class Transient(TimeIntegration):
    """The load steps at ``frequency`` (rad/s) as time histories."""

    type: ClassVar[str] = "transient"
    frequency: float


def check(c: Checking) -> None:
    """Its frequency, ramp and outputs; what time integration cannot take."""
    a, pre = c.table, c.pre
    number(f"{pre}.frequency", a.get("frequency"), c.out, positive=True)
    for k in ("ramp_time", "settle_time"):
        number(f"{pre}.{k}", a[k], c.out, nonneg=True)
    number(f"{pre}.ramp_periods", a["ramp_periods"], c.out, nonneg=True, integer=True)
    rules.output_faults(c)
    rules.time_integration_faults(c)
    rules.friction_laws_only(c)


def seconds(data: dict, spec: Transient, variant: dict | None = None) -> float:
    """The load steps: the ramp and settling at the one frequency."""
    return time_integration_seconds(data, (spec.frequency,), spec.ramp_time,
                                    spec.settle_time, spec.ramp_periods, 0,
                                    spec.steps_per_period)


def run_transient(case: Case, spec: Transient, group: h5py.Group, run: Run
                  ) -> tuple[str, str]:
    """The two load steps as time histories; the picture."""
    from microslip.solve import dti

    c, hb, names, idx, tm, loads = time_model(case, spec)
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
            "contacts": attr_list([ct.name for ct in hb.contacts])})
    draw_analysis(pictures.transient, group, spec, run)
    return "complete", ""


KIND = AnalysisKind("transient", Transient, check, seconds, run_transient, pictures.transient,
                    size=size)
