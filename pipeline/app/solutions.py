"""The solutions an FRF draws maps of: the refined resonance peak and every solution at a
given parameter value, with their patch states and (for shape pictures) each body's
displacements on its outer surface; the response measures they are ranked by; and what a
branch's points write of their contacts (states, dissipation, static forces, patches)."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from microslip.results import schema
from microslip.results.writer import ATTRS
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import (
    Response,
    between,
    output,
    refine_peak,
    response_measure,
    solve_point,
)

if TYPE_CHECKING:
    from microslip.assembly.recovery import PatchState


def response_at(hb, x: np.ndarray, point: OperatingPoint, rows, measure: str) -> np.ndarray:
    """(n_outputs,) response measure of one solution."""
    coef = output(hb.recover(x, point), rows)
    return response_measure(hb.harmonics, coef[None], measure)[0]


def sampling_change(r: Response, i: int, rows, measure: str) -> tuple[float, float]:
    """(relative change of the response measure, shift of the parameter) of point ``i`` of
    a branch when the period is sampled twice as finely, to first order, normal to the
    branch (:meth:`Response.sampling_shift`); the response's largest change over the
    outputs relative to their largest response. NaN where it cannot be estimated."""
    dx, dp = r.sampling_shift(i)
    if not np.isfinite(dp):
        return float("nan"), float("nan")
    x, point = r.branch.x[i], r.point(i)
    m0 = response_at(r.model, x, point, rows, measure)
    m1 = response_at(r.model, x + dx, point.set(r.parameter, r.values[i] + dp), rows, measure)
    return float(np.max(np.abs(m1 - m0)) / (np.max(np.abs(m0)) or 1.0)), dp


def map_solutions(r: Response, wanted: list, rows, measure: str, settings
                  ) -> list[tuple[str, float, np.ndarray]]:
    """(what, parameter value, x) of the solutions a curve draws maps of.

    "peak": the largest response of the first output, refined by Brent's method between
    its computed neighbours (:func:`refined_peak`; the computed point if no trial does
    better). A number: every solution of the branch at that parameter value (a fold gives
    several: :meth:`Response.solutions_at`)."""
    hb = r.model
    if not len(r):
        return []
    shown = np.array([response_at(hb, x, r.point(i), rows, measure)[0]
                      for i, x in enumerate(r.branch.x)])
    out = []
    for w in wanted:
        if w == "peak":
            out.append(("peak", *refined_peak(r, shown, rows, measure, settings)))
            continue
        at = r.base.set(r.parameter, w)
        found = sorted(r.solutions_at(w, settings),  # the highest first, as a fold's upper
                       key=lambda x: -response_at(hb, x, at, rows, measure)[0])  # branch
        for k, x in enumerate(found):
            out.append((f"{r.parameter} = {w:.7g}, solution {k + 1} of {len(found)}", float(w),
                        x))
    return out


PEAK_XTOL = 1e-4  # the refined peak's parameter to this share of its bracket


def refined_peak(r: Response, shown: np.ndarray, rows, measure: str, settings
                  ) -> tuple[float, np.ndarray]:
    """(parameter value, x) at the largest response of the first output (map_solutions):
    :func:`refine_peak` between the computed neighbours of the largest computed point,
    each trial a Newton solve from the solutions so far on either side of it, interpolated
    (next to a natural sweep's jump: the nearest); the computed point if no trial does
    better."""
    lam = r.values
    i = int(np.argmax(shown))
    if not (0 < i < len(r) - 1 and (lam[i] - lam[i - 1]) * (lam[i + 1] - lam[i]) > 0):
        return float(lam[i]), r.branch.x[i]  # at an end of the branch, or on a fold
    tried = {float(lam[j]): r.branch.x[j] for j in (i - 1, i, i + 1)}
    # next to a natural sweep's jump the neighbours lie on two branches: no mix of them
    across = any(i in jump for jump in r.branch.jumps)
    # the trials' scale: their neighbours' largest unknown, not a stuck linear solve each
    scale = float(max(np.abs(x).max(initial=0.0) for x in tried.values()))

    def response(v: float) -> float:
        point = r.base.set(r.parameter, v)
        sol = solve_point(r.model, point, settings=settings,
                          x0=between(tried, v, interpolate=not across), retry=False,
                          explain=False, x_scale=scale or None)
        if not sol.converged:
            return 0.0
        tried[v] = sol.x
        return float(response_at(r.model, sol.x, point, rows, measure)[0])

    lo, hi = sorted((float(lam[i - 1]), float(lam[i + 1])))
    v, top = refine_peak(response, lo, hi, PEAK_XTOL * (hi - lo))
    return (v, tried[v]) if top > shown[i] else (float(lam[i]), r.branch.x[i])


def map_groups(cm, r: Response, solutions, rows, measure: str,
                normalise: bool = False, surfaces: dict | None = None) -> dict:
    """The maps/ subgroups of a curve: per solution (what, parameter value, x[, its
    operating point: by default the curve's at that value]) its parameter, response (per
    unit excitation with ``normalise``), unknowns and patch states (the pictures letter them a,
    b, c... over the analysis); with ``surfaces`` (body -> its surface nodes), each body's
    displacement coefficients there, ``shapes/<body>`` (p, 3, n_coeffs) [m]."""
    groups = {}
    for k, (what, v, x, *given) in enumerate(solutions):
        point = given[0] if given else r.base.set(r.parameter, v)
        patches = cm.patches(x, point)
        response = response_at(r.model, x, point, rows, measure)
        groups[schema.point(k)] = {
            ATTRS: {"what": what, "parameter": v, "omega": point.omega,
                    "excitation": point.excitation},
            "unknowns": x, "response": response / point.excitation if normalise else response,
            schema.PATCHES: {p: {"state": s.state, "static": s.static,
                            "slip_share": s.slip_share} for p, s in patches.items()}}
        if surfaces:
            groups[schema.point(k)][schema.SHAPES] = {
                ATTRS: {"orders": list(r.model.harmonics.orders),
                        "wave_numbers": list(cm.wave_numbers())},
                **{body: cm.displacements(x, point, body, nodes)[1]
                   for body, nodes in surfaces.items()}}
    return groups


def surfaces(mesh) -> dict[str, np.ndarray]:
    """Per body its outer-surface vertices (sorted global node indices): where deformed
    shapes are recovered and drawn."""
    return {body: np.unique(mesh.surface(body)) for body in sorted(mesh.bodies)}


#: samples per period of a stored hysteresis loop at most: a picture's, not the balance's
LOOP_SAMPLES = 64


def contact_rows(r: Response) -> tuple[list, list]:
    """Every contact's evaluation at every point of a branch, without its time histories
    (a fine grid's would not fit in memory over a branch), and per point and contact its
    hysteresis loop: (the contact point dissipating most there, u (d, s) [m], T (d, s) [N])
    at every ``ceil(ns / LOOP_SAMPLES)``-th sample of the period (float32: a picture's)."""
    per_point, loops = [], []
    for i in range(len(r)):
        rows = r.contacts(i, histories=True)
        loops.append([_loop(x) for x in rows])
        per_point.append([replace(x, T=None, N=None, u=None, v=None, flags=None)
                          for x in rows])
    return per_point, loops


def _loop(x) -> tuple[int, np.ndarray, np.ndarray]:
    p = int(np.argmax(x.dissipation))  # all stuck: the first point
    step = -(-x.u.shape[-1] // LOOP_SAMPLES)
    return (p, x.u[p, :, ::step].astype(np.float32), x.T[p, :, ::step].astype(np.float32))


def contact_data(r: Response, per_point: list, loops: list | None = None) -> dict:
    """Per contact and point: state, dissipation, slip fraction, static forces (and the
    names of their columns per contact point); with ``loops`` (:func:`contact_rows`) the
    hysteresis loop of the point dissipating most (``loop_point``, ``loop_u``,
    ``loop_T``)."""
    out = {}
    for ci, c in enumerate(r.model.contacts):
        rows = [contacts[ci] for contacts in per_point]
        el = c.elements
        if el.coupled and r.model.harmonics.has_static:  # (no point: a curve without start)
            static = np.array([x.forces[:, :, 0].ravel() for x in rows],
                              dtype=float).reshape(len(rows), el.size * el.n_components)
        elif el.variable_normal:
            # uncoupled: the static forces assumed a priori, N0 (T0 not modelled: NaN)
            n0 = np.array([el.n0 * r.point(i).preload for i in range(len(r))],
                          dtype=float).reshape(len(r), el.size)
            static = np.concatenate([np.full((len(r), el.size * el.dim), np.nan), n0], axis=1)
        else:
            static = np.zeros((len(r), 0))
        columns = [f"T0_{j + 1}" if el.dim > 1 else "T0" for j in range(el.dim)]
        columns += ["N0"] if el.variable_normal else []
        out[c.name] = {
            "state": np.array([x.state[0] for x in rows], dtype=np.int8),
            "node_state": np.array([x.state for x in rows], dtype=np.int8),
            "dissipation": np.array([x.dissipation.sum() for x in rows]),
            "slip_fraction": np.array([x.slip_fraction.mean() for x in rows]),
            "static_force": static,
            "columns": np.array(columns if static.shape[1] else [], dtype="S"),
            "undersampled": np.array([x.undersampled.sum() for x in rows]),
        }
        if loops:
            out[c.name] |= {"loop_point": np.array([lp[ci][0] for lp in loops]),
                            "loop_u": np.array([lp[ci][1] for lp in loops]),
                            "loop_T": np.array([lp[ci][2] for lp in loops])}
    return out


def patch_data(states: list[dict[str, PatchState]]) -> dict:
    """Per patch and point (n points, P node pairs): state (n, P), static forces
    [T0_1, T0_2, N0] (n, P, 3) [N], the share of slipping node pairs (n,)."""
    if not states:
        return {}
    return {p: {"state": np.array([s[p].state for s in states], dtype=np.int8),
                "static": np.array([s[p].static for s in states]),
                "slip_share": np.array([s[p].slip_share for s in states])}
            for p in states[0]}
