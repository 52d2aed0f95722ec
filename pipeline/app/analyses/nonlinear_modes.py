"""``type = "nonlinear_modes"``: a nonlinear mode of the model (extended periodic motion
concept, ``solve.nonlinear_modes``): its natural frequency and damping ratio against the
vibration level, the contacts' states and dissipation per level, and the resonance peak at
each excitation level synthesized from it (``solve.modal_synthesis``: Firrone & Zucca
Figs. 6 and 22 from one backbone per design)."""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import ClassVar

import h5py
import numpy as np

from microslip.case import Case, curve_variants, operating_point, settings, task_seconds
from microslip.case import analysis_rules as rules
from microslip.case.checks import is_number, number
from microslip.case.estimate import CURVE_POINTS, balance_point_seconds
from microslip.case.kinds import AnalysisKind, Checking
from microslip.case.specs import Analysis, Family
from microslip.draw import backbones
from microslip.results import schema
from microslip.solve.modal_synthesis import forced_check, peak, synthesis
from microslip.solve.nonlinear_modes import Backbone, ModalBalance, backbone
from microslip.solve.response import output, response_measure

from ..models import AssemblyModels, LumpedModels
from ..plan import PlanContext, Stage, curve_stages
from ..running import (
    Progress,
    Run,
    cached_curve,
    computed_curves,
    draw_analysis,
    member_identity,
    outputs,
    ticker,
    worst,
)
from ..solutions import contact_data, map_groups, patch_data
from ..tasks import Outcome, Task

#: how a backbone starts: from the linear mode with the contacts stuck, or removed
STARTS = ("stuck", "free")
#: A synthesized peak further than this from the direct solve at its frequency is told to
#: the user: single-mode synthesis does not hold there (the check's error is about
#: twice the synthesis' own against the FRF peak: 1.2e-3 / 8e-4 at zeta 2.7 %, 9.5e-3 /
#: 4.4e-3 at 13 %, 0.68 / 0.10 at 24 % on the Jenkins oscillator).
DOMINANCE = 0.01
@dataclass(frozen=True, kw_only=True)
class NonlinearModes(Analysis):
    """Linear mode number ``mode`` (1: the lowest elastic one of the fundamental harmonic,
    contacts ``start``: stuck or removed) continued as a nonlinear mode over the levels at
    which ``output``'s fundamental would be ``amplitude`` = [low, high] m on the linear
    mode's shape (the modal amplitudes the backbone runs over; the output's own amplitude
    there follows the shape's change with the level; ``measure``: its response,
    max_t |x(t)| or with ``vibration`` max_t |x(t) - x0|); at every level the natural
    frequency, the damping ratio, the output's response, the contacts' states and
    dissipation. ``excitations``: the resonance peak synthesized at these multipliers of
    the case's excitation. ``maps`` (an assembly case): the contact-status and static
    normal-load maps (``map_types``) at the levels where the output's response is these
    amplitudes [m]. ``family``: a backbone per member (a design study from modes)."""

    type: ClassVar[str] = "nonlinear_modes"
    output: str
    amplitude: tuple[float, float]
    mode: int = 1
    start: str = "stuck"
    excitations: tuple[float, ...] = ()
    measure: str = "peak"
    maps: tuple[float, ...] = ()
    map_types: tuple[str, ...] = ("status", "normal_load")
    family: Family | None = None


def check(c: Checking) -> None:
    """The output, the amplitude range, the mode number, the start, the excitations."""
    a, pre = c.table, c.pre
    rules.output_fault(c)
    rules.sector_only(c)
    amp = a["amplitude"]
    if not (isinstance(amp, list) and len(amp) == 2 and all(is_number(v) for v in amp)
            and 0 < amp[0] < amp[1]):
        c.out.append(f"{pre}.amplitude = {amp!r}: expected [low, high] m with 0 < low < "
                     "high (the output's amplitude on the linear mode's shape)")
    number(f"{pre}.mode", a["mode"], c.out, positive=True, integer=True)
    if a["start"] not in STARTS:
        c.out.append(f"{pre}.start = {a['start']!r}: expected 'stuck' (the linear mode with "
                     "every contact stuck) or 'free' (the contacts removed)")
    ex = a["excitations"]
    if not (isinstance(ex, list) and all(is_number(v) and v > 0 for v in ex)):
        c.out.append(f"{pre}.excitations = {ex!r}: expected a list of multipliers > 0 of "
                     "the case's excitation (the peaks synthesized from the mode)")
    rules.family_faults(c)
    rules.measure_faults(c, ("peak", "vibration"))
    _map_faults(c)


def _map_faults(c: Checking) -> None:
    """``maps``: output amplitudes > 0 (an assembly case's); ``map_types``: status and
    normal_load."""
    a, pre = c.table, c.pre
    if not (isinstance(a["maps"], list) and all(is_number(v) and v > 0 for v in a["maps"])):
        c.out.append(f"{pre}.maps = {a['maps']!r}: expected a list of output amplitudes "
                     "> 0 [m] (the levels of the contact maps)")
    elif a["maps"] and "assembly" not in c.data:
        c.out.append(f"{pre}.maps: contact maps need an [assembly] case (patches)")
    kinds = a["map_types"]
    if not (isinstance(kinds, list) and set(kinds) <= {"status", "normal_load"}):
        c.out.append(f"{pre}.map_types = {kinds!r}: expected a list of 'status' and "
                     "'normal_load'")


def seconds(data: dict, spec: NonlinearModes, variant: dict | None = None) -> float:
    """One backbone: at most as many levels as an FRF curve has points (1 / step: 50 at
    the default), each about a balance point (its Newton on the same structured or dense
    Jacobian, bordered by two rows and columns)."""
    return CURVE_POINTS * balance_point_seconds(data, spec, variant)


def plan(case: Case, spec: NonlinearModes, context: PlanContext) -> list[Stage]:
    """Its pictures and a backbone per family member."""
    return curve_stages(case, spec, context, ("backbone",),
                        lambda c, method: context.store.key(c.data, spec.table(),
                                                            curve="backbone"))


def run_modes(case: Case, spec: NonlinearModes, group: h5py.Group, run: Run
              ) -> tuple[str, str]:
    """A backbone per family member (a task each), then the pictures; (status, message)
    of the worst."""
    name, store = spec.name, run.store
    hits, keys = store.hits, []
    statuses: dict[int, tuple[str, str]] = {}
    tasks: list[Task] = []
    targets: list[tuple[int, str, str]] = []
    each = task_seconds(case.data, spec)
    for j, (variant, label, value) in enumerate(curve_variants(case, spec)):
        which = f"[{name}] backbone {j + 1} {label}".rstrip()
        key = store.key(variant.data, spec.table(), curve="backbone")
        keys.append(key)
        kept = cached_curve(store, key, group, schema.curve(j), f"{which}: {{}} levels",
                            run.progress, member_identity(spec, label, value))
        if kept:
            statuses[j] = kept
            continue
        tasks.append(Task(mode_task, (variant, spec, label, value, which), which, each))
        targets.append((j, key, schema.curve(j)))
    statuses |= computed_curves(run, group, tasks, targets, f"[{name}] ")
    draw_analysis(backbones.draw, group, spec, run, keys, store.hits - hits == len(keys))
    return worst([statuses[k] for k in sorted(statuses)])


def mode_task(models: LumpedModels | AssemblyModels, c: Case, spec: NonlinearModes,
              label: str, value, which: str, *, progress: Progress, live: bool = True
              ) -> Outcome:
    """One backbone of the case variant ``c`` with its synthesized peaks: a task."""
    names, idx = outputs(c, (spec.output,), models)
    hb = models.model(c)
    t = time.perf_counter()
    try:
        modal = ModalBalance(hb, operating_point(c, 1.0))
        start = _start(modal, spec)
    except ValueError as err:
        return Outcome({}, {}, "failed", f"{which}: {err}")
    # the output's amplitude in the linear mode (its shared DOFs' shape as one column)
    out = float(np.abs(output(start.shape[:hb.linear.n_dof, None], idx))[0, 0])
    if not out > 0:
        return Outcome({}, {}, "failed", f"{which}: the output {spec.output} does not move "
                       f"in linear mode {spec.mode} (at {start.omega:.6g} rad/s)")
    lo, hi = (a / out for a in spec.amplitude)
    base = settings(c)
    mode = backbone(modal, start, (lo, hi),
                    settings=replace(base, step=min(base.step * 2, base.max_step)),
        progress=ticker(progress, which, np.log10(lo), np.log10(hi)) if live else None)
    elapsed = time.perf_counter() - t
    b = mode.branch
    if not len(mode.amplitude) and b.status == "stopped":
        b.status = "failed"
    data = _levels(modal, mode, idx, models, c, spec) | _synthesized(modal, mode, spec, idx)
    warnings = tuple(_dominance_warnings(data, spec, which))
    attrs = member_identity(spec, label, value) | {
        "status": b.status, "message": b.message, "elapsed_s": elapsed, "outputs": names,
        "harmonic_orders": list(hb.harmonics.orders), "samples": hb.harmonics.n_samples,
        "linear_omega": start.omega, "linear_xi": start.xi, "start": spec.start,
        "mode": spec.mode}
    done = f"{which}: {len(mode.amplitude)} levels, {b.status} ({elapsed:.2f} s) {b.message}"
    return Outcome(data, attrs, b.status, b.message, (done.rstrip(), *warnings))


def _start(modal: ModalBalance, spec: NonlinearModes):
    """The linear mode the backbone starts from; ValueError when there are fewer."""
    modes = modal.linear_modes(spec.mode, stuck=spec.start == "stuck")
    if len(modes) < spec.mode:
        raise ValueError(f"mode = {spec.mode}: the linear system ({spec.start}) has "
                         f"{len(modes)} elastic modes")
    return modes[spec.mode - 1]


def _levels(modal: ModalBalance, mode: Backbone, idx, models, c: Case,
            spec: NonlinearModes) -> dict:
    """Per level: the mode's numbers, the output's response, the energies and contacts."""
    hb = modal.model
    r = mode.response()
    n = len(r)
    coef = r.coefficients(idx) if n else np.zeros((0, 1, hb.harmonics.n_coeffs))
    per_point = [r.contacts(i) for i in range(n)]
    energies = [modal.energies(x, w, xi, contacts) for x, w, xi, contacts in
                zip(mode.x, mode.omega, mode.xi, per_point)]
    data = {
        "modal_amplitude": mode.amplitude, "omega": mode.omega, "xi": mode.xi,
        "damping_ratio": mode.damping_ratio, "coefficients": coef,
        "response": response_measure(hb.harmonics, coef, spec.measure) if n
        else np.zeros((0, 1)),
        "dissipation": np.array([e["friction"] + e["normal"] for e in energies]),
        "viscous": np.array([e["viscous"] for e in energies]),
        "residual": r.branch.residuals, "iterations": r.branch.iterations,
        "unknowns": mode.x, "unknown_dofs": hb.dofs,
        schema.CONTACTS: contact_data(r, per_point),
    }
    if isinstance(models, AssemblyModels):
        from microslip.assembly.recovery import patch_states

        cm = models.assembly(c)
        names_c = [ct.name for ct in hb.contacts]
        data[schema.PATCHES] = patch_data([patch_states(names_c, cm.points, p)
                                           for p in per_point])
        wanted = _map_levels(modal, mode, data["response"][:, 0], spec.maps)
        if wanted:
            data[schema.MAPS] = map_groups(cm, r, wanted, idx, "peak")
    return data


def _map_levels(modal: ModalBalance, mode: Backbone, response: np.ndarray,
                amplitudes: tuple[float, ...]) -> list[tuple]:
    """(what, amplitude, x, point) of the levels where the output's response first reaches
    each of ``amplitudes`` (interpolated in log a, then solved exactly there)."""
    out = []
    for A in amplitudes:
        above = np.flatnonzero(response >= A)
        if not len(above) or above[0] == 0:
            continue
        i = above[0] - 1
        t = np.log(A / response[i]) / np.log(response[i + 1] / response[i])
        a = float(np.exp((1 - t) * np.log(mode.amplitude[i])
                         + t * np.log(mode.amplitude[i + 1])))
        level = mode.at(a)
        if level is None:
            continue
        x, w, xi = level
        out.append((f"level {A:.3g} m (w = {w:.6g} rad/s, zeta = {100 * xi / (2 * w):.3g} %)",
                    float(A), x, modal.at(w, xi)))
    return out


def _synthesized(modal: ModalBalance, mode: Backbone, spec: NonlinearModes, idx) -> dict:
    """The excitation whose resonance peak is at each level, and the peaks at the
    analysis' excitations (each level solved exactly where the peak is)."""
    if not len(mode.amplitude):
        return {}
    syn = synthesis(modal, mode)
    h = modal.model.harmonics
    out = {"peak_excitation": syn.peak_excitation, "peak_frequency": syn.peak_frequency,
           "modal_force": np.abs(syn.modal_force)}
    if not spec.excitations:
        return out
    found = [peak(modal, mode, syn, e) for e in spec.excitations]
    nan = np.full(1, np.nan)  # (one output)
    checked = [None if p is None else forced_check(modal, p) for p in found]

    def measured(x: np.ndarray, point) -> np.ndarray:
        return response_measure(h, output(modal.model.recover(x, point), idx), spec.measure)

    out |= {"excitations": np.array(spec.excitations, dtype=float),
            "peak_response": np.array([
                nan if p is None else measured(p.x, modal.at(p.omega, p.xi)) for p in found]),
            "peak_check": np.array([nan if x is None else measured(
                x, modal.forced(p.frequency, p.excitation)) for p, x in zip(found, checked)]),
            "peak_damping_ratio": np.array([np.nan if p is None else p.xi / (2 * p.omega)
                                            for p in found]),
            "peak_omega": np.array([np.nan if p is None else p.frequency for p in found]),
            "peak_modal_amplitude": np.array([np.nan if p is None else p.amplitude
                                              for p in found]),
            "frequencies": np.array([np.stack(syn.frequencies(e)) for e in spec.excitations])}
    return out


def _dominance_warnings(data: dict, spec: NonlinearModes, which: str):
    """A line per synthesized peak further than DOMINANCE from the direct solve there."""
    for e, syn, chk, zeta in zip(data.get("excitations", ()), data.get("peak_response", ()),
                                 data.get("peak_check", ()),
                                 data.get("peak_damping_ratio", ())):
        if not np.isfinite(syn[0]):
            continue
        if not np.isfinite(chk[0]):
            yield (f"warning: {which}: at excitation x{e:g} the direct solve at the "
                   "synthesized peak failed: the synthesized peak is unchecked; compute an "
                   "frf there")
            continue
        error = abs(syn[0] / chk[0] - 1.0)
        if error > DOMINANCE:
            yield (f"warning: {which}: the peak synthesized at excitation x{e:g} "
                   f"({syn[0]:.4g} m) is {100 * error:.3g} % from the direct solve at its "
                   f"frequency ({chk[0]:.4g} m): single-mode synthesis does not hold there "
                   f"(damping ratio {100 * zeta:.3g} %: strongly damped, or another mode "
                   "near); compute an frf there")


KIND = AnalysisKind("nonlinear_modes", NonlinearModes, check, seconds, run_modes,
                    backbones.draw, plan=plan, kernels=True, assembly=True)
