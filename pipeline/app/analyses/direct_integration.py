"""``type = "dti"``: steady responses by direct time integration at each frequency, the
reference the harmonic balance is checked against (Firrone & Zucca 4.1, Figs. 10-12)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import h5py
import numpy as np

from microslip.case import Case
from microslip.case import analysis_rules as rules
from microslip.case.checks import number
from microslip.case.estimate import STEADY_PERIODS, time_integration_seconds
from microslip.case.kinds import AnalysisKind, Checking
from microslip.case.specs import MEASURES, Analysis, LoadTable
from microslip.draw import pictures
from microslip.fourier import Harmonics
from microslip.results import schema
from microslip.results.writer import ATTRS
from microslip.solve.response import response_measure

from ..running import Run, draw_analysis, time_model


@dataclass(frozen=True, kw_only=True)
class TimeIntegration(Analysis):
    """The load steps of a time integration: the static loads ramped over ``ramp_time``
    (s), held ``settle_time``; the harmonic loads ramped over ``ramp_periods`` periods;
    ``steps_per_period`` time steps per excitation period."""

    type: ClassVar[str] = ""
    outputs: tuple[str, ...] | None = None
    steps_per_period: int = 256
    ramp_time: float = 0.0
    settle_time: float = 0.0
    ramp_periods: int = 0

@dataclass(frozen=True, kw_only=True)
class Dti(TimeIntegration):
    """Steady responses at ``frequencies`` (rad/s) by direct time integration, at most
    ``max_periods`` periods each; ``restart``: each from fresh load steps (else from the
    previous steady state); ``compare``: the frf analysis drawn with it."""

    type: ClassVar[str] = "dti"
    frequencies: tuple[float, ...]
    max_periods: int = 3000
    measure: str = "peak"
    restart: bool = False
    compare: str = ""


def check(c: Checking) -> None:
    """Its measure, outputs, frequencies, steps and ramp; what time integration cannot
    take (springs, a lag, loads beyond harmonic 1); the analysis it is compared with."""
    a, pre = c.table, c.pre
    rules.measure_faults(c, MEASURES)
    rules.flag(c, "restart", "")
    rules.output_faults(c)
    rules.friction_laws_only(c)
    f = a.get("frequencies")
    if not (isinstance(f, list) and f and all(
            isinstance(x, (int, float)) and x > 0 for x in f)):
        c.out.append(f"{pre}.frequencies = {f!r}: expected a list of frequencies > 0 (rad/s)")
    for k in ("steps_per_period", "max_periods"):
        number(f"{pre}.{k}", a[k], c.out, positive=True, integer=True)
    number(f"{pre}.ramp_periods", a["ramp_periods"], c.out, nonneg=True, integer=True)
    for k in ("ramp_time", "settle_time"):
        number(f"{pre}.{k}", a[k], c.out, nonneg=True)
    rules.time_integration_faults(c)
    orders = {ld.get("harmonic", LoadTable.harmonic) for ld in c.data.get("loads", [])}
    if not orders <= {0, 1}:
        c.out.append(f"{pre}: time integration takes loads of harmonic 0 and 1 only, the "
                     f"case has {sorted(orders)}")
    names = [x.get("name") for x in c.data.get("analysis", []) if isinstance(x, dict)]
    if a["compare"] and a["compare"] not in names:  # "": no comparison
        c.out.append(f"{pre}.compare = {a['compare']!r}: no analysis of that name; known: "
                     f"{names}")


def seconds(data: dict, spec: Dti, variant: dict | None = None) -> float:
    """The whole integration: the load steps, the ramp and STEADY_PERIODS periods to the
    steady state per frequency."""
    return time_integration_seconds(data, spec.frequencies, spec.ramp_time, spec.settle_time,
                                    spec.ramp_periods, min(spec.max_periods, STEADY_PERIODS),
                                    spec.steps_per_period)


def size(name: str, data: dict, table: dict):
    """A handful of dense DOF x DOF matrices."""
    from microslip.case.estimate import Size

    n = len(data["model"]["dofs"])
    return Size(name, n, 8 * 8 * n * n, f"{n} DOFs, time integration")


def run_dti(case: Case, spec: Dti, group: h5py.Group, run: Run) -> tuple[str, str]:
    """Steady responses by time integration at each frequency; the pictures."""
    from microslip.solve import dti

    name, progress = spec.name, run.progress
    c, hb, names, idx, tm, loads = time_model(case, spec)
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
    draw_analysis(pictures.dti, group, spec, run)
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


def _normal(hb, contact: str) -> bool:
    return next(c for c in hb.contacts if c.name == contact).elements.variable_normal


KIND = AnalysisKind("dti", Dti, check, seconds, run_dti, pictures.dti, size=size,
                    pictures_per_output=True)
