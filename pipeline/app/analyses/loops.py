"""``type = "loops"``: the hysteresis loops of one contact law under a prescribed relative
motion, one per amplitude (Firrone & Zucca Figs. 3 and 9)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import h5py
import numpy as np

from microslip.case import Case, contact_elements
from microslip.case.checks import samples_rule
from microslip.case.estimate import LOOPS_S, Size
from microslip.case.kinds import AnalysisKind, Checking
from microslip.case.specs import Analysis, analysis
from microslip.draw import pictures
from microslip.fourier import Harmonics
from microslip.laws.registry import LAWS
from microslip.results import schema
from microslip.solve.hbm import CACHE_LIMIT
from microslip.solve.memory import ContactShape, balance_bytes

from ..running import Run, draw_analysis


@dataclass(frozen=True, kw_only=True)
class Loops(Analysis):
    """Hysteresis loops of ``contact`` under a prescribed motion [cos, sin] amplitudes
    (m): ``u`` (``u2``: the second direction of a 2D law; ``v``: the normal motion of laws
    B, D), one loop per multiplier in ``amplitudes``, which scale the whole motion
    (``scale = "all"``) or only ``v``; ``samples`` per period."""

    type: ClassVar[str] = "loops"
    contact: str
    u: tuple[float, float]
    amplitudes: tuple[float, ...]
    u2: tuple[float, float] | None = None
    v: tuple[float, float] = (0.0, 0.0)
    scale: str = "all"
    samples: int = 512


def check(c: Checking) -> None:
    """Its contact, amplitudes, prescribed motion, scale and samples."""
    a, pre = c.table, c.pre
    if a.get("contact") not in c.contacts:
        c.out.append(f"{pre}.contact = {a.get('contact')!r}: unknown contact; known: "
                     f"{sorted(c.contacts)}")
    amps = a.get("amplitudes")
    if not (isinstance(amps, list) and amps and all(
            isinstance(x, (int, float)) for x in amps)):
        c.out.append(f"{pre}.amplitudes: expected a non-empty list of multipliers of the "
                     "prescribed motion")
    for k in ("u", "u2", "v"):
        m = a.get(k)
        if m is None:
            if k == "u":
                c.out.append(f"{pre}.u: missing; the prescribed tangential motion as "
                             "[cos amplitude, sin amplitude] (m)")
            continue
        if not (isinstance(m, list) and len(m) == 2 and all(
                isinstance(x, (int, float)) for x in m)):
            c.out.append(f"{pre}.{k} = {m!r}: expected [cos amplitude, sin amplitude] (m)")
    if a["scale"] not in ("all", "v"):
        c.out.append(f"{pre}.scale = {a.get('scale')!r}: expected 'all' (the amplitudes "
                     "multiply the whole motion) or 'v' (only the normal motion)")
    samples_rule(f"{pre}.samples", a["samples"], 1, c.out)  # the loops keep orders 0, 1


def seconds(data: dict, spec: Loops, variant: dict | None = None) -> float:
    """The loops, whole: one evaluation of the law per amplitude."""
    return LOOPS_S


def size(name: str, data: dict, table: dict) -> Size:
    """One law at orders 0, 1 under a prescribed motion, per amplitude."""
    c = next(c for c in data["contacts"] if c.get("name") == table["contact"])
    law = LAWS[c["law"]]
    shape = ContactShape(len(table["amplitudes"]), len(law.motions), getattr(law, "dim", 0), 0)
    samples = analysis(table, Loops).samples
    nbytes = balance_bytes(0, 0, 2, 3, samples, [shape], 1, CACHE_LIMIT)
    return Size(name, 0, nbytes, "prescribed motion")


def run_loops(case: Case, spec: Loops, group: h5py.Group, run: Run) -> tuple[str, str]:
    """The loops of one contact law under the prescribed motion, one per amplitude (the
    contact as the case, its ``set`` applied, gives it); the picture."""
    variant = case.with_values(spec.set)
    table = next(c for c in variant.data["contacts"] if c.get("name") == spec.contact)
    amps = np.asarray(spec.amplitudes, dtype=float)
    base = contact_elements(table)
    el = type(base)(base.law, np.repeat(base.kt, amps.size, 0), np.repeat(base.kn, amps.size),
                    np.repeat(base.mu, amps.size), np.repeat(base.n0, amps.size), base.coupled)
    h = Harmonics([0, 1], spec.samples)
    motion = [spec.u] + ([spec.u2] if el.dim == 2 else []) + (
        [spec.v] if el.variable_normal else [])
    g = np.zeros((amps.size, el.n_components, 3))
    scale_v_only = el.variable_normal and spec.scale == "v"
    for j, (ca, sa) in enumerate(motion):
        is_v = el.variable_normal and j == el.n_components - 1
        factor = amps if (is_v or not scale_v_only) else np.ones_like(amps)
        g[:, j, 1], g[:, j, 2] = factor * ca, factor * sa
    r = el.evaluate(g, h, jacobian=False, histories=True)
    scaled = el.n_components - 1 if scale_v_only else 0  # the motion the amplitudes scale
    data = {"amplitude": amps, "u": r.u, "v": r.v, "T": r.T, "N": r.N,
            "dissipation": r.dissipation, "state": r.state.astype(np.int8),
            "motion_amplitude": amps * np.hypot(*motion[scaled])}
    run.writer.write_group(group, schema.curve(0), data, {
        "label": f"loops of {spec.contact}", "status": "complete", "message": "",
        "law": el.law, "contact": spec.contact, "dim": el.dim, "mu": float(base.mu[0]),
        "motion": "v" if scale_v_only else ("u_x" if el.dim == 2 else "u")})
    draw_analysis(pictures.loops, group, spec, run)
    return "complete", ""


KIND = AnalysisKind("loops", Loops, check, seconds, run_loops, pictures.loops, size=size,
                    kernels=True)
