"""The linear limits drawn with an assembly's FRF or peak curve: the free blisk (no damper, or
no contact) and the fully stuck system (every contact its stick springs), solved directly
order by order over the FRF's range or at the peak of a window."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from microslip.case import Case, curve_variants, operating_point
from microslip.case.specs import Analysis
from microslip.results import schema
from microslip.results.writer import ResultsWriter
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import refine_peak, response_measure

from .models import AssemblyModels

Progress = Callable[[str], None]


def linear_limits(models: AssemblyModels, case: Case, spec: Analysis, writer: ResultsWriter, group,
                  store, progress: Progress) -> None:
    """The free blisk (no damper) and the fully stuck system over the FRF's range, solved
    directly (linear): written beside the curves (the pictures draw them with them). The
    stuck system once per damper mass the curves have (a mass family: one each)."""
    names = (models.expanded(case, list(spec.outputs)) if spec.outputs is not None
             else models.names(case))
    measure = spec.measure
    ws = np.linspace(spec.start, spec.stop, LINEAR_POINTS)
    variants = {}  # mass multiplier -> (case variant, assembly model, operating point)
    for c, _, _ in curve_variants(case, spec):
        point = operating_point(c, spec.omega)
        variants.setdefault(point.mass_multiplier, (c, point))
    masses = sorted(variants)
    # the free limit is the cyclic bodies alone: drawn only where every output is on them
    # (a blade held by its root joint has no free limit)
    cm0 = models.assembly(variants[masses[0]][0])
    cyclic = np.zeros(cm0.hb.linear.n_dof, dtype=bool)
    for b in cm0.layout:
        cyclic[b.offset: b.offset + b.n_masters] = b.disk
    free = all(not np.any(cm0.outputs[n][~cyclic]) for n in names)
    runs = [("free", free_label(cm0), masses[0], schema.LINEAR_FREE)] if free else []
    for k, m in enumerate(masses):
        runs.append(("stuck", "fully stuck" + (f", mass x {m:g}" if len(masses) > 1 else ""),
                     m, schema.linear_stuck(k, len(masses))))
    t = time.perf_counter()
    for springs, label, m, key in runs:
        c, base = variants[m]
        stored = store.key(c.data, spec.table(), curve="linear", springs=springs,
                           points=LINEAR_POINTS, peak_points=PEAK_POINTS, outputs=names)
        if store.load(stored, group, key):
            group[key].attrs["label"] = label
            continue
        ws_all, coef, shown = linear_curve(models.assembly(c), base, springs, names, measure,
                                            ws)
        if spec.normalise:  # linear: the same for every excitation level
            shown = shown / base.excitation
        writer.write_group(group, key, {"omega": ws_all, "coefficients": coef, "response": shown},
                      {"label": label, "status": "complete", "message": "linear, solved "
                       "directly", "mass_multiplier": m})
        store.save(stored, group[key])
    progress(f"[{spec.name}] linear limits ({len(runs)} curves) in {time.perf_counter() - t:.1f} s")


def free_label(cm) -> str:
    """What the free limit is: the cyclic bodies without the damper (a body of their own),
    or without their contacts (a shroud, a blade root)."""
    return "free (no damper)" if any(not b.disk for b in cm.layout) else "free (no contact)"


def linear_curve(cm, base: OperatingPoint, springs: str, names: list[str], measure: str,
                  ws: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(frequencies, coefficients, response) of a linear limit on the grid ``ws`` and,
    since a lightly damped peak is narrower than the grid, PEAK_POINTS more around each
    local maximum of the first output, within a grid spacing on either side."""
    static = measure == "peak"  # vibration and harmonic measures leave order 0 out

    def response(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        coef = np.array([cm.linear_outputs(base.set("frequency", f), springs, names, static)
                         for f in x])
        return coef, response_measure(cm.hb.harmonics, coef, measure)

    coef, shown = response(ws)
    peaks = [i for i in range(1, ws.size - 1)
             if shown[i, 0] >= shown[i - 1, 0] and shown[i, 0] >= shown[i + 1, 0]]
    if not peaks:
        return ws, coef, shown
    extra = np.concatenate([np.linspace(ws[i - 1], ws[i + 1], PEAK_POINTS + 2)[1:-1]
                            for i in peaks])
    c2, s2 = response(extra)
    order = np.argsort(np.concatenate([ws, extra]), kind="stable")
    return (np.concatenate([ws, extra])[order], np.concatenate([coef, c2])[order],
            np.concatenate([shown, s2])[order])


LINEAR_POINTS = 201  # frequencies of the linear limits drawn with an assembly's FRF
PEAK_POINTS = 24  # more frequencies around each peak of a linear limit


LEVEL_POINTS = 5  # parameter values at which the fully stuck peak level is computed


def peak_levels(cm, base: OperatingPoint, par: str, values: np.ndarray, output_name: str,
                 window: tuple[float, float], vibration: bool, writer: ResultsWriter, group,
                 progress,
                 name: str) -> None:
    """The linear levels of a peak curve: the free blisk's peak (one value: no damper, no
    parameter) and the fully stuck system's at LEVEL_POINTS values spread as ``values``."""
    t = time.perf_counter()
    ends = values[[0, -1]]
    spread = (np.geomspace if values[0] > 0 and np.allclose(
        values, np.geomspace(values[0], values[-1], values.size)) else np.linspace)
    picks = spread(values[0], values[-1], min(LEVEL_POINTS, values.size))
    for springs, pars in (("free", ends), ("stuck", picks)):
        peaks = [linear_peak(cm, base.set(par, v), springs, output_name, window, vibration)
                 for v in (pars[:1] if springs == "free" else pars)]
        if springs == "free":
            peaks = peaks * 2
        level = schema.LEVEL_FREE if springs == "free" else schema.LEVEL_STUCK
        writer.write_group(group, level, {
            "parameter": pars, "omega": np.array([p[0] for p in peaks]),
            "amplitude": np.array([p[1] for p in peaks])},
            {"label": free_label(cm) if springs == "free" else "fully stuck",
             "status": "complete", "message": "linear, solved directly"})
    progress(f"[{name}] free and fully stuck peak levels in {time.perf_counter() - t:.1f} s")


def linear_peak(cm, point: OperatingPoint, springs: str, output_name: str | list[str],
                window: tuple[float, float], vibration: bool,
                grid: int = 101) -> tuple[float, float]:
    """(w, amplitude) of the largest response of a linear limit of an assembly model in a
    frequency window (of any of the outputs, given a list: every blade's): a grid, then
    :func:`refine_peak` between the grid neighbours of its maximum (to 1e-6 of the
    window)."""
    h = cm.hb.harmonics
    names = [output_name] if isinstance(output_name, str) else list(output_name)

    def amp(x: float) -> float:
        coef = cm.linear_outputs(point.set("frequency", x), springs, names,
                                 static=not vibration)
        return float(np.max(response_measure(h, coef, "vibration" if vibration else "peak")))

    ws = np.linspace(*window, grid)
    peaks = np.array([amp(x) for x in ws])
    i = int(np.argmax(peaks))
    lo, hi = ws[max(i - 1, 0)], ws[min(i + 1, grid - 1)]
    omega, top = refine_peak(amp, lo, hi, 1e-6 * (window[1] - window[0]))
    return (omega, top) if top >= peaks[i] else (float(ws[i]), float(peaks[i]))
