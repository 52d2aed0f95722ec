"""Case files (TOML) for lumped models: parse, validate, build.

A case names its DOFs and writes M, K, C directly; contacts give their law,
form, parameters and the relative displacements as linear combinations of
named DOFs (seed eqs. 21-23); loads are amplitude and phase per DOF and
harmonic (order 0: static). Analyses (``[[analysis]]``) say what to compute:

frf      a sweep of ``frequency`` | ``excitation`` | ``preload`` | ``mass`` by
         arclength or natural continuation, optionally one curve per value of
         a ``family`` key (any case key, e.g. ``contacts.wall.n0``)
         (coupled cases: ``maps`` at the peak or at given values, every solution there)
peak     the largest response over a frequency window against a parameter:
         optimization (preload, mass) and performance (excitation) curves
loops    hysteresis loops / 2D force trajectories of one contact law under a
         prescribed relative motion, one per amplitude
dti      direct time integration at given frequencies (the reference the
         text compares against)

Every fault found is reported, one line each, naming the key, the value and
what is allowed, before anything is computed (:class:`CaseError`). The key
reference with units and defaults is in the README.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from microslip.pipeline.friction.harmonics import Harmonics, default_samples
from microslip.pipeline.friction.laws import LAWS, ContactElements
from microslip.pipeline.solve.continuation import Settings
from microslip.pipeline.solve.hbm import (
    CACHE_LIMIT,  # bounds what the solver's cache holds: the memory estimate reads it
    PARAMETERS,
    Contact,
    Excitation,
    HarmonicBalance,
    LinearDynamics,
    OperatingPoint,
)

from . import coupled
from .checks import (
    ContactShape,
    available_memory,
    balance_bytes,
    is_int,
    is_number,
    memory_text,
    number,
    samples_rule,
    unknown_keys,
)
from .structure import check as check_reduction

ANALYSES = ("frf", "peak", "loops", "dti", "transient")
METHODS = ("arclength", "natural", "natural-down")  # natural-down: from stop to start
# peak: max_t |x(t)|; vibration: max_t |x(t) - x0| (static part removed); harmonic: |X_1|
MEASURES = ("peak", "vibration", "harmonic")
TOP_KEYS = {"title", "description", "model", "contacts", "loads", "harmonics", "solver",
            "analysis", "geometry", "reduction", "coupling"}
MODEL_KEYS = {"dofs", "mass", "stiffness", "damping", "mass_part"}
CONTACT_KEYS = {"name", "law", "form", "kt", "kn", "mu", "n0", "interference", "u", "u1", "u2",
                "v", "enabled"}
LOAD_KEYS = {"dof", "amplitude", "harmonic", "phase"}
HARMONIC_KEYS = {"max", "orders", "samples"}
SOLVER_KEYS = {"tol", "max_iter", "step", "min_step", "max_step", "max_turn", "target_iter",
               "max_points", "sub_sample"}
ANALYSIS_KEYS = {
    "frf": {"type", "name", "parameter", "start", "stop", "method", "frequency", "outputs",
            "family", "set", "measure", "maps", "map_types", "normalise"},
    "peak": {"type", "name", "parameter", "start", "stop", "window", "output", "points", "set",
             "family", "spacing", "tracking", "measure", "levels"},
    "loops": {"type", "name", "contact", "u", "u2", "v", "amplitudes", "scale", "samples"},
    "dti": {"type", "name", "frequencies", "outputs", "steps_per_period", "ramp_periods",
            "ramp_time", "settle_time", "max_periods", "set", "compare", "restart", "measure"},
    "transient": {"type", "name", "frequency", "outputs", "steps_per_period", "ramp_periods",
                  "ramp_time", "settle_time", "set"},
}
FAMILY_KEYS = {"key", "values", "label", "sets"}


class CaseError(ValueError):
    """All faults found in a case file, one per line."""

    def __init__(self, source: str, faults: list[str]):
        self.faults = faults
        super().__init__(f"{source}: {len(faults)} fault(s)\n" + "\n".join(
            f"  - {f}" for f in faults))


@dataclass(frozen=True)
class Case:
    """A validated case: the raw table (as run) plus its content hash."""

    data: dict
    source: str

    @property
    def title(self) -> str:
        return self.data.get("title", Path(self.source).stem)

    @property
    def analyses(self) -> list[dict]:
        return self.data.get("analysis", [])

    @property
    def dofs(self) -> list[str]:
        return list(self.data["model"]["dofs"])

    @property
    def content_hash(self) -> str:
        blob = json.dumps(self.data, sort_keys=True, default=str).encode()
        return hashlib.sha256(blob).hexdigest()

    def contacts_enabled(self) -> list[str]:
        """Names of the contacts the model includes, in order."""
        return [c.get("name", f"contact{i}") for i, c in enumerate(self.data.get("contacts", []))
                if c.get("enabled", True)]

    def with_value(self, key: str, value: Any) -> Case:
        """A copy with one key set (dotted path; arrays of tables by name or index)."""
        return self.with_values({key: value})

    def with_values(self, values: dict[str, Any]) -> Case:
        """A copy with keys set; validated again (a value may break a rule)."""
        if not values:
            return self
        data = copy.deepcopy(self.data)
        for key, value in values.items():
            _set_path(data, key, value, create=True)
        # memory=False: load bounded every analysis with its set and family already, against
        # the memory free then (a run's own arrays must not refuse its later curves)
        check(data, self.source, memory=False)
        return Case(data, self.source)


# --------------------------------------------------------------------- loading
def load(path: str | Path) -> Case:
    """Read and validate a case file; raises CaseError listing every fault."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except OSError as err:
        raise CaseError(str(path), [f"cannot read the file: {err.strerror}"]) from None
    except UnicodeDecodeError as err:  # tomllib decodes first: a binary file lands here
        raise CaseError(str(path), [
            f"not a text file: byte 0x{err.object[err.start]:02x} at offset {err.start} is "
            "not UTF-8; a case file is TOML text (UTF-8)"]) from None
    except tomllib.TOMLDecodeError as err:
        raise CaseError(str(path), [f"not valid TOML: {err}"]) from None
    check(data, str(path))
    return Case(data, str(path))


def check(data: dict, source: str = "case", *, memory: bool = True) -> None:
    """Validate a case table; raises CaseError with one line per fault. With ``memory``, a
    valid case whose largest analysis needs more than the machine's available memory
    (:func:`sizes`) is refused too, before anything is built."""
    faults: list[str] = []
    _check(data, faults)
    if not faults and memory:
        _memory(data, faults)
    if faults:
        raise CaseError(source, faults)


def _check(data: dict, out: list[str], analyses: bool = True) -> None:
    unknown_keys("", data, TOP_KEYS, out)
    if "geometry" in data:
        _geometry(data["geometry"], out)
    if "reduction" in data:
        check_reduction(data["reduction"], data, out)
    if "coupling" in data:
        _check_coupled(data, out, analyses)
        return
    if "geometry" in data and "model" not in data and "analysis" not in data:
        _harmonics(data.get("harmonics", {}), out)  # the NDs of an engine order use them
        return  # a mesh (and reduction) case
    model = data.get("model")
    if not isinstance(model, dict):
        out.append("[model]: missing; give dofs, mass, stiffness (and damping)")
        return
    unknown_keys("model.", model, MODEL_KEYS, out)
    dofs = model.get("dofs")
    if not (isinstance(dofs, list) and dofs and all(isinstance(d, str) for d in dofs)):
        out.append(f"model.dofs = {dofs!r}: expected a non-empty list of DOF names")
        return
    if len(set(dofs)) != len(dofs):
        out.append(f"model.dofs = {dofs!r}: names must be unique")
        return
    n = len(dofs)
    for key, required, positive in (("mass", True, True), ("stiffness", True, False),
                                    ("damping", False, False), ("mass_part", False, False)):
        if key not in model:
            if required:
                out.append(f"model.{key}: missing; give {n} diagonal values or a {n}x{n} matrix")
            continue
        _matrix(f"model.{key}", model[key], n, positive, out)
    names = set(dofs)
    contacts = data.get("contacts", [])
    if not isinstance(contacts, list):
        out.append("contacts: expected an array of tables [[contacts]]")
        contacts = []
    seen = set()
    for i, c in enumerate(contacts):
        _contact(i, c, names, seen, out)
    for i, load in enumerate(data.get("loads", [])):
        _load(i, load, names, out)
    _harmonics(data.get("harmonics", {}), out)
    _solver(data.get("solver", {}), out)
    if analyses:
        for i, a in _analysis_tables(data, ANALYSES, out):
            _analysis(i, a, data, seen, names, out)


def _analysis_tables(data: dict, kinds: tuple[str, ...], out: list[str]) -> list:
    """(index, table) of the case's [[analysis]], or a fault if there is none."""
    items = data.get("analysis", [])
    if not isinstance(items, list) or not items:
        out.append(f"analysis: missing; add at least one [[analysis]] with type in "
                   f"{list(kinds)}")
        return []
    return list(enumerate(items))


def _check_coupled(data: dict, out: list[str], analyses: bool) -> None:
    """A case of reduced FE bodies joined by friction patches ([coupling])."""
    coupled.check(data["coupling"], data, out)
    for key in ("contacts", "loads"):
        if key in data:
            out.append(f"{key}: a coupled case gives its contacts and loads in [coupling]")
    _harmonics(data.get("harmonics", {}), out)
    _solver(data.get("solver", {}), out)
    if not analyses:
        return
    outputs = set(coupled.output_names(data))
    for i, a in _analysis_tables(data, coupled.ANALYSES, out):
        if isinstance(a, dict) and a.get("type") not in coupled.ANALYSES:
            out.append(f"analysis.{a.get('name', i)}.type = {a.get('type')!r}: a coupled case "
                       f"runs {list(coupled.ANALYSES)}")
            continue
        if isinstance(a, dict) and a.get("parameter", "frequency") not in coupled.PARAMETERS:
            out.append(f"analysis.{a.get('name', i)}.parameter = {a.get('parameter')!r}: a "
                       f"coupled case sweeps {list(coupled.PARAMETERS)}")
            continue
        _analysis(i, a, data, set(), outputs, out)


def _matrix(key: str, value, n: int, positive: bool, out: list[str]) -> None:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        out.append(f"{key} = {value!r}: expected {n} numbers or a {n}x{n} matrix")
        return
    if arr.shape == (n,):
        if not np.all(np.isfinite(arr)):
            out.append(f"{key}: values must be finite")
        elif positive and np.any(arr <= 0):
            out.append(f"{key} = {value!r}: diagonal values must be > 0")
        elif not positive and key != "model.mass_part" and np.any(arr < 0):
            out.append(f"{key} = {value!r}: diagonal values must be >= 0")
        return
    if arr.shape != (n, n):
        out.append(f"{key}: shape {arr.shape}, expected ({n},) or ({n}, {n}) for {n} DOFs")
        return
    if not np.all(np.isfinite(arr)):
        out.append(f"{key}: values must be finite")
        return
    if not np.allclose(arr, arr.T, rtol=1e-12, atol=1e-12 * np.abs(arr).max()):
        out.append(f"{key}: the matrix is not symmetric (max |A - A^T| = "
                   f"{np.abs(arr - arr.T).max():.3g})")
        return
    eig = np.linalg.eigvalsh(arr)
    if positive and eig.min() <= 0:
        out.append(f"{key}: the matrix must be positive definite (smallest eigenvalue "
                   f"{eig.min():.3g})")
    elif not positive and key in ("model.stiffness", "model.damping") and \
            eig.min() < -1e-12 * max(abs(eig).max(), 1e-300):
        out.append(f"{key}: the matrix must be positive semi-definite (smallest eigenvalue "
                   f"{eig.min():.3g})")


def _combination(key: str, value, dofs: set[str], out: list[str]) -> None:
    if not isinstance(value, dict) or not value:
        out.append(f"{key} = {value!r}: expected a table {{dof = coefficient, ...}}")
        return
    for d, coef in value.items():
        if d not in dofs:
            out.append(f"{key}.{d}: unknown DOF; known: {sorted(dofs)}")
        elif isinstance(coef, dict):
            # a delayed DOF: coef * x(t - lag T), a travelling motion (harmonic balance only)
            unknown_keys(f"{key}.{d}.", coef, {"coef", "lag"}, out)
            number(f"{key}.{d}.coef", coef.get("coef", 1.0), out)
            number(f"{key}.{d}.lag", coef.get("lag", 0.0), out)
        else:
            number(f"{key}.{d}", coef, out)


def _has_lag(data: dict) -> bool:
    return any(isinstance(coef, dict) for c in data.get("contacts", [])
               for k in ("u", "u1", "u2", "v") if isinstance(c.get(k), dict)
               for coef in c[k].values())


def _contact(i: int, c, dofs: set[str], seen: set[str], out: list[str]) -> None:
    pre = f"contacts[{i}]"
    if not isinstance(c, dict):
        out.append(f"{pre}: expected a table")
        return
    name = c.get("name", f"contact{i}")
    pre = f"contacts.{name}"
    if name in seen:
        out.append(f"{pre}: duplicate contact name")
    seen.add(name)
    unknown_keys(pre + ".", c, CONTACT_KEYS, out)
    law = c.get("law")
    if law not in LAWS:
        out.append(f"{pre}.law = {law!r}: expected one of {sorted(LAWS)}")
        return
    d, variable = LAWS[law]
    form = c.get("form", "uncoupled")
    if form not in ("uncoupled", "coupled"):
        out.append(f"{pre}.form = {form!r}: expected 'uncoupled' or 'coupled'")
    kt = c.get("kt")
    if isinstance(kt, list):
        if len(kt) != d:
            out.append(f"{pre}.kt = {kt!r}: expected one value or {d} (kt_x, kt_y)")
        for j, k in enumerate(kt):
            number(f"{pre}.kt[{j}]", k, out, positive=True)
    elif kt is None:
        out.append(f"{pre}.kt: missing (tangential contact stiffness, N/m)")
    else:
        number(f"{pre}.kt", kt, out, positive=True)
    if "mu" not in c:
        out.append(f"{pre}.mu: missing (friction coefficient)")
    else:
        number(f"{pre}.mu", c["mu"], out, nonneg=True)
    if variable:
        if "kn" not in c:
            out.append(f"{pre}.kn: missing (normal contact stiffness, N/m) for law {law}")
        else:
            number(f"{pre}.kn", c["kn"], out, positive=True)
    elif "kn" in c:
        out.append(f"{pre}.kn: law {law} has a constant normal load; remove kn")
    coupled_var = form == "coupled" and variable
    if coupled_var:
        if "n0" in c:
            out.append(f"{pre}.n0: the coupled form of law {law} takes 'interference' (m), "
                       "not n0")
        if "interference" not in c:
            out.append(f"{pre}.interference: missing (m, negative for a gap)")
        else:
            number(f"{pre}.interference", c["interference"], out)
    else:
        if "interference" in c:
            out.append(f"{pre}.interference: only the coupled form of laws B and D takes it")
        if "n0" not in c:
            out.append(f"{pre}.n0: missing (normal preload, N)")
        else:
            number(f"{pre}.n0", c["n0"], out, nonneg=not variable)
    if "enabled" in c and not isinstance(c["enabled"], bool):
        out.append(f"{pre}.enabled = {c['enabled']!r}: expected true or false")
    tangential = ["u"] if d == 1 else ["u1", "u2"]
    wrong = ["u1", "u2"] if d == 1 else ["u"]
    for k in tangential:
        if k not in c:
            out.append(f"{pre}.{k}: missing (tangential relative displacement as "
                       "{dof = coefficient})")
        else:
            _combination(f"{pre}.{k}", c[k], dofs, out)
    for k in wrong:
        if k in c:
            out.append(f"{pre}.{k}: law {law} is {d}D; use {tangential}")
    if variable:
        if "v" not in c:
            out.append(f"{pre}.v: missing (normal relative displacement, positive on approach)")
        else:
            _combination(f"{pre}.v", c["v"], dofs, out)
    elif "v" in c:
        out.append(f"{pre}.v: law {law} has a constant normal load; remove v")


def _load(i: int, load, dofs: set[str], out: list[str]) -> None:
    pre = f"loads[{i}]"
    if not isinstance(load, dict):
        out.append(f"{pre}: expected a table")
        return
    unknown_keys(pre + ".", load, LOAD_KEYS, out)
    if load.get("dof") not in dofs:
        out.append(f"{pre}.dof = {load.get('dof')!r}: unknown DOF; known: {sorted(dofs)}")
    if "amplitude" not in load:
        out.append(f"{pre}.amplitude: missing (N)")
    else:
        number(f"{pre}.amplitude", load["amplitude"], out)
    number(f"{pre}.harmonic", load.get("harmonic", 1), out, nonneg=True, integer=True)
    number(f"{pre}.phase", load.get("phase", 0.0), out)


def _harmonics(h, out: list[str]) -> None:
    unknown_keys("harmonics.", h, HARMONIC_KEYS, out)
    if not isinstance(h, dict):
        return
    if "max" in h and "orders" in h:
        out.append("harmonics: give either 'max' (orders 0..max) or 'orders', not both")
    if "max" in h:
        number("harmonics.max", h["max"], out, nonneg=True, integer=True)
    top = h.get("max", 1)
    if "orders" in h:
        o = h["orders"]
        if not (isinstance(o, list) and o and all(isinstance(x, int) and x >= 0 for x in o)):
            out.append(f"harmonics.orders = {o!r}: expected a list of integers >= 0")
            return
        top = max(o)
    if "samples" in h and is_int(top) and top >= 0:
        samples_rule("harmonics.samples", h["samples"], top, out)


def _solver(s, out: list[str]) -> None:
    unknown_keys("solver.", s, SOLVER_KEYS, out)
    if not isinstance(s, dict):
        return
    for k in ("tol", "step", "min_step", "max_step", "max_turn"):
        if k in s:
            number(f"solver.{k}", s[k], out, positive=True)
    for k in ("max_iter", "target_iter", "max_points"):
        if k in s:
            number(f"solver.{k}", s[k], out, positive=True, integer=True)
    if "sub_sample" in s and not isinstance(s["sub_sample"], bool):
        out.append(f"solver.sub_sample = {s['sub_sample']!r}: expected true or false")


def _analysis(i: int, a, data: dict, contacts: set[str], dofs: set[str],
              out: list[str]) -> None:
    pre = f"analysis[{i}]"
    if not isinstance(a, dict):
        out.append(f"{pre}: expected a table")
        return
    kind = a.get("type")
    if kind not in ANALYSES:
        out.append(f"{pre}.type = {kind!r}: expected one of {list(ANALYSES)}")
        return
    pre = f"analysis.{a.get('name', i)}"
    unknown_keys(pre + ".", a, ANALYSIS_KEYS[kind], out)
    overrides = a.get("set", {})
    if not isinstance(overrides, dict):
        out.append(f"{pre}.set: expected a table {{\"key.path\" = value}}")
    else:
        _overrides(f"{pre}.set", data, overrides, out)
    if kind in ("frf", "peak"):
        par = a.get("parameter", "frequency")
        allowed = PARAMETERS if kind == "frf" else ("excitation", "preload", "mass")
        if par not in allowed:
            out.append(f"{pre}.parameter = {par!r}: expected one of {list(allowed)}")
        ok = all(number(f"{pre}.{k}", a.get(k), out) for k in ("start", "stop"))
        if ok and a["start"] == a["stop"]:
            out.append(f"{pre}: start = stop = {a['start']}: the range has zero length")
        if ok and (par == "frequency" or par == "mass") and min(a["start"], a["stop"]) <= 0:
            out.append(f"{pre}: {par} range {a['start']}..{a['stop']} must be > 0")
        if kind == "frf" and par != "frequency":
            if not number(f"{pre}.frequency", a.get("frequency"), out, positive=True):
                out.append(f"{pre}.frequency: the fixed frequency (rad/s) of a {par} sweep")
        if kind == "frf":
            methods = a.get("method", "arclength")
            methods = methods if isinstance(methods, list) else [methods]
            for m in methods:
                if m not in METHODS:
                    out.append(f"{pre}.method = {m!r}: expected one of {list(METHODS)} (or a "
                               "list of them: one curve each)")
        if kind == "peak":
            w = a.get("window")
            if not (isinstance(w, list) and len(w) == 2 and all(
                    isinstance(x, (int, float)) and x > 0 for x in w) and w[0] < w[1]):
                out.append(f"{pre}.window = {w!r}: expected [w_low, w_high] in rad/s, "
                           "0 < w_low < w_high")
            if a.get("output") not in dofs:
                out.append(f"{pre}.output = {a.get('output')!r}: unknown DOF; known: "
                           f"{sorted(dofs)}")
            if "points" in a:
                number(f"{pre}.points", a["points"], out, positive=True, integer=True)
            if a.get("tracking", "continuation") not in ("continuation", "sweep"):
                out.append(f"{pre}.tracking = {a.get('tracking')!r}: expected 'continuation' "
                           "(the peak followed from value to value) or 'sweep' (a full FRF "
                           "per value)")
            sp = a.get("spacing", "linear")
            if sp not in ("linear", "log"):
                out.append(f"{pre}.spacing = {sp!r}: expected 'linear' or 'log'")
            elif sp == "log" and ok and min(a["start"], a["stop"]) <= 0:
                out.append(f"{pre}.spacing = 'log' needs start and stop > 0")
        fam = a.get("family")
        if fam is not None:
            _family(pre, fam, data, out)
        if kind == "frf" and ("maps" in a or "map_types" in a):
            _maps(pre, a, data, out)
        if kind == "frf" and not isinstance(a.get("normalise", False), bool):
            out.append(f"{pre}.normalise = {a['normalise']!r}: expected true or false (the "
                       "response per unit of the excitation multiplier)")
    if kind == "peak" and a.get("measure", "peak") not in ("peak", "vibration"):
        out.append(f"{pre}.measure = {a.get('measure')!r}: expected 'peak' or 'vibration'")
    if kind == "peak" and "levels" in a and not isinstance(a["levels"], bool):
        out.append(f"{pre}.levels = {a['levels']!r}: expected true or false (the free and "
                   "fully stuck peak levels, a coupled case)")
    if kind in ("frf", "dti"):
        if a.get("measure", "peak") not in MEASURES:
            out.append(f"{pre}.measure = {a.get('measure')!r}: expected one of {list(MEASURES)}")
        if "restart" in a and not isinstance(a["restart"], bool):
            out.append(f"{pre}.restart = {a['restart']!r}: expected true or false")
        for o in a.get("outputs", []):
            if o not in dofs:
                out.append(f"{pre}.outputs: {o!r} is not a DOF; known: {sorted(dofs)}")
    if kind == "loops":
        if a.get("contact") not in contacts:
            out.append(f"{pre}.contact = {a.get('contact')!r}: unknown contact; known: "
                       f"{sorted(contacts)}")
        amps = a.get("amplitudes")
        if not (isinstance(amps, list) and amps and all(
                isinstance(x, (int, float)) for x in amps)):
            out.append(f"{pre}.amplitudes: expected a non-empty list of multipliers of the "
                       "prescribed motion")
        for k in ("u", "u2", "v"):
            m = a.get(k)
            if m is None:
                if k == "u":
                    out.append(f"{pre}.u: missing; the prescribed tangential motion as "
                               "[cos amplitude, sin amplitude] (m)")
                continue
            if not (isinstance(m, list) and len(m) == 2 and all(
                    isinstance(x, (int, float)) for x in m)):
                out.append(f"{pre}.{k} = {m!r}: expected [cos amplitude, sin amplitude] (m)")
        if a.get("scale", "all") not in ("all", "v"):
            out.append(f"{pre}.scale = {a.get('scale')!r}: expected 'all' (the amplitudes "
                       "multiply the whole motion) or 'v' (only the normal motion)")
        if "samples" in a:  # the loops keep orders 0 and 1 (run.run_loops)
            samples_rule(f"{pre}.samples", a["samples"], 1, out)
    if kind == "transient":
        number(f"{pre}.frequency", a.get("frequency"), out, positive=True)
        for k in ("ramp_time", "settle_time"):
            number(f"{pre}.{k}", a.get(k, 0.0), out, nonneg=True)
        number(f"{pre}.ramp_periods", a.get("ramp_periods", 0), out, nonneg=True,
                integer=True)
        for o in a.get("outputs", []):
            if o not in dofs:
                out.append(f"{pre}.outputs: {o!r} is not a DOF; known: {sorted(dofs)}")
        if _has_lag(data):
            out.append(f"{pre}: time integration cannot delay a DOF (a contact kinematics "
                       "with 'lag'); use harmonic balance")
    if kind == "dti":
        f = a.get("frequencies")
        if not (isinstance(f, list) and f and all(
                isinstance(x, (int, float)) and x > 0 for x in f)):
            out.append(f"{pre}.frequencies = {f!r}: expected a list of frequencies > 0 (rad/s)")
        for k in ("steps_per_period", "max_periods"):
            if k in a:
                number(f"{pre}.{k}", a[k], out, positive=True, integer=True)
        if "ramp_periods" in a:
            number(f"{pre}.ramp_periods", a["ramp_periods"], out, nonneg=True, integer=True)
        for k in ("ramp_time", "settle_time"):
            if k in a:
                number(f"{pre}.{k}", a[k], out, nonneg=True)
        if _has_lag(data):
            out.append(f"{pre}: time integration cannot delay a DOF (a contact kinematics "
                       "with 'lag'); use harmonic balance")
        orders = {ld.get("harmonic", 1) for ld in data.get("loads", [])}
        if not orders <= {0, 1}:
            out.append(f"{pre}: time integration takes loads of harmonic 0 and 1 only, the "
                       f"case has {sorted(orders)}")
        names = [x.get("name") for x in data.get("analysis", []) if isinstance(x, dict)]
        if "compare" in a and a["compare"] not in names:
            out.append(f"{pre}.compare = {a['compare']!r}: no analysis of that name; known: "
                       f"{names}")


MAP_TYPES = ("status", "normal_load", "shape")


def wants_shapes(data: dict) -> bool:
    """Whether an frf of the case draws deformed shapes at its map points: then every body
    is recovered on its outer surface too."""
    return any(isinstance(a, dict) and a.get("maps") and "shape" in a.get("map_types", [])
               for a in data.get("analysis", []))


def _maps(pre: str, a: dict, data: dict, out: list[str]) -> None:
    """``maps``: where an frf draws its contact maps ("peak", or parameter values: every
    solution there); ``map_types``: which maps."""
    if "coupling" not in data:
        out.append(f"{pre}.maps: contact maps need contact patches: a [coupling] case")
        return
    where = a.get("maps", [])
    lo, hi = sorted((a.get("start", 0.0), a.get("stop", 0.0)))
    if not isinstance(where, list):
        out.append(f"{pre}.maps = {where!r}: expected a list of 'peak' and parameter values")
        where = []
    for x in where:
        if x != "peak" and not (is_number(x) and lo <= x <= hi):
            out.append(f"{pre}.maps: {x!r} is neither 'peak' nor a parameter value in the "
                       f"range {lo:g}..{hi:g}")
    kinds = a.get("map_types", ["status"])
    if not (isinstance(kinds, list) and all(k in MAP_TYPES for k in kinds)):
        out.append(f"{pre}.map_types = {kinds!r}: expected a list of {list(MAP_TYPES)}")


def _family(pre: str, fam, data: dict, out: list[str]) -> None:
    if not isinstance(fam, dict):
        out.append(f"{pre}.family: expected a table with key and values")
        return
    unknown_keys(pre + ".family.", fam, FAMILY_KEYS, out)
    vals = fam.get("values")
    if not (isinstance(vals, list) and vals):
        out.append(f"{pre}.family.values: expected a non-empty list")
        return
    if "sets" in fam:
        # one curve per table of overrides; values are the curves' labels
        sets = fam["sets"]
        if "key" in fam:
            out.append(f"{pre}.family: give 'key' or 'sets', not both")
        if not (isinstance(sets, list) and len(sets) == len(vals)
                and all(isinstance(x, dict) for x in sets)):
            out.append(f"{pre}.family.sets: expected {len(vals)} tables of overrides, one per "
                       "value")
            return
        for j, table in enumerate(sets):
            _overrides(f"{pre}.family.sets[{j}]", data, table, out)
        return
    key = fam.get("key")
    try:
        _get_path(data, key)
    except (KeyError, IndexError, TypeError, ValueError):
        out.append(f"{pre}.family.key = {key!r}: no such key in the case (use e.g. "
                   "'contacts.<name>.n0' or 'loads.0.amplitude')")
        return
    if key.startswith("harmonics."):  # each value moves H or the samples: the same rule
        for j, v in enumerate(vals):
            _overrides(f"{pre}.family.values[{j}]", data, {key: v}, out)


def _overrides(pre: str, data: dict, table: dict, out: list[str]) -> None:
    """Apply overrides to a copy and validate it: a key may be new (e.g.
    ``contacts.x.enabled``) if its table exists; what it breaks is reported."""
    if not table:
        return
    trial = copy.deepcopy({k: v for k, v in data.items() if k != "analysis"})
    base: list[str] = []
    _check(trial, base, analyses=False)
    for key, value in table.items():
        try:
            _set_path(trial, key, value, create=True)
        except (KeyError, IndexError, TypeError, ValueError):
            out.append(f"{pre}.{key}: no such table in the case")
            return
    found: list[str] = []
    _check(trial, found, analyses=False)
    out.extend(f"{pre}: {f}" for f in found if f not in base)  # only what the overrides break


def _geometry(geo, out: list[str]) -> None:
    from microslip import geometry

    if not isinstance(geo, dict) or geo.get("model") not in geometry.MODELS:
        out.append(f"geometry.model = {geo.get('model') if isinstance(geo, dict) else geo!r}: "
                   f"expected one of {sorted(geometry.MODELS)}")
        return
    unknown_keys("geometry.", geo, {"model", "parameters"}, out)
    params = geo.get("parameters", {})
    if not isinstance(params, dict):
        out.append("geometry.parameters: expected a table")


# --------------------------------------------------------------- sizes and notes
@dataclass(frozen=True)
class Size:
    """What one analysis will hold: the real unknowns of its harmonic balance (of a time
    integration: the DOFs; loops prescribe the motion and have none) and its peak memory."""

    analysis: str
    unknowns: int
    nbytes: int
    detail: str = ""  # what sets the size (for a refusal)

    def __str__(self) -> str:
        what = f"{self.unknowns:,} unknowns" if self.unknowns else "no unknowns (prescribed motion)"
        return f"{self.analysis}, {what}, {memory_text(self.nbytes)}"


def sizes(data: dict) -> list[Size]:
    """Per analysis of a valid case, the estimate for its largest curve (its ``set``, then
    each ``family`` value or table applied), from the case's numbers alone: nothing is
    built, so check and run refuse what will not fit before any work."""
    out = []
    for i, a in enumerate(data.get("analysis", [])):
        name = str(a.get("name", i))
        out.append(max((_size(name, v, a) for v in _variants(data, a)),
                       key=lambda s: s.nbytes))
    return out


def _memory(data: dict, out: list[str]) -> None:
    """A fault per analysis whose estimate exceeds the memory available now."""
    limit = available_memory()
    for s in sizes(data) if limit is not None else []:
        if s.nbytes > limit:
            out.append(f"analysis.{s.analysis}: needs {memory_text(s.nbytes)} "
                       f"({s.unknowns:,} real unknowns: {s.detail}) but "
                       f"{limit / 1e9:.1f} GB of memory is available; lower harmonics.max "
                       "(or harmonics.orders), harmonics.samples or the contact DOFs")


def _variants(data: dict, a: dict) -> list[dict]:
    """The case as each curve of analysis ``a`` sees it."""
    base = copy.deepcopy({k: v for k, v in data.items() if k != "analysis"})
    for key, value in a.get("set", {}).items():
        _set_path(base, key, value, create=True)
    fam = a.get("family") or {}
    tables = fam.get("sets", [])
    if "key" in fam:
        tables = [{fam["key"]: v} for v in fam["values"]]
    variants = []
    for table in tables:
        v = copy.deepcopy(base)
        for key, value in table.items():
            _set_path(v, key, value, create=True)
        variants.append(v)
    return variants or [base]


def _size(name: str, data: dict, a: dict) -> Size:
    kind = a.get("type")
    if kind in ("dti", "transient"):  # a handful of dense DOF x DOF matrices
        n = len(data["model"]["dofs"])
        return Size(name, n, 8 * 8 * n * n, f"{n} DOFs, time integration")
    if kind == "loops":  # one law at orders 0, 1 under a prescribed motion, per amplitude
        c = next(c for c in data["contacts"] if c.get("name") == a["contact"])
        d, variable = LAWS[c["law"]]
        shape = ContactShape(len(a["amplitudes"]), d + variable, d, 0)
        nbytes = balance_bytes(0, 0, 2, 3, a.get("samples", 512), [shape], 1, CACHE_LIMIT)
        return Size(name, 0, nbytes, "prescribed motion")
    if "coupling" in data:
        contact_dofs, shapes = _patch_contacts(data)
        linear_dofs = contact_dofs  # a lower bound: the modes and other masters come later
    else:
        contact_dofs, shapes = _lumped_contacts(data)
        linear_dofs = len(data["model"]["dofs"])
    h = harmonics(Case(data, ""))
    points = data.get("solver", {}).get("max_points", Settings().max_points)
    nbytes = balance_bytes(contact_dofs, linear_dofs, len(h.orders), h.n_coeffs, h.n_samples,
                           shapes, points, CACHE_LIMIT)
    detail = (f"{contact_dofs:,} contact DOF(s) x {h.n_coeffs:,} coefficients, H = "
              f"{max(h.orders)}, {h.n_samples:,} samples per period")
    return Size(name, contact_dofs * h.n_coeffs, nbytes, detail)


def _lumped_contacts(data: dict) -> tuple[int, list[ContactShape]]:
    """(DOFs any enabled contact touches, one shape per contact) of a lumped case."""
    touched: set[str] = set()
    shapes = []
    for c in data.get("contacts", []):
        if not c.get("enabled", True):
            continue
        d, variable = LAWS[c["law"]]
        keys = (["u"] if d == 1 else ["u1", "u2"]) + (["v"] if variable else [])
        mine = {dof for k in keys for dof in c[k]}
        shapes.append(ContactShape(1, len(keys), d, len(mine)))
        touched |= mine
    return len(touched), shapes


def _patch_contacts(data: dict) -> tuple[int, list[ContactShape]]:
    """(contact DOFs, shapes) of a coupled case from its contact grids, known before meshing:
    a patch has n_axial x n_flank node pairs, each pair a node of each body (3 DOFs each)."""
    from microslip import geometry

    geo = data["geometry"]
    given = geo.get("parameters", {})
    fields = {f.name: f.default for f in dataclasses.fields(geometry.PARAMETERS[geo["model"]])}

    def count(key: str) -> int:
        v = given.get(key, fields[key])
        return v if is_int(v) and v > 0 else fields[key]  # a bad value is refused at meshing

    pairs = count("contact_n_axial") * count("contact_n_flank")
    shapes = []
    for c in data["coupling"]["contacts"]:
        if c.get("elements", "2D") == "2D":
            shapes.append(ContactShape(pairs, 3, 2, 6))
        else:  # two law-B elements (t1 or t2, and n)
            shapes += [ContactShape(pairs, 2, 1, 6)] * 2
    return 6 * pairs * len(data["coupling"]["contacts"]), shapes


def notes(data: dict) -> list[str]:
    """Remarks on a valid lumped case that are not faults: a contact so much stiffer than
    the structure it touches that the time sampling, not the contact, sets the accuracy.

    After a reversal of u = U cos(theta) a Jenkins contact sticks until u has come back
    2 u_s, u_s = mu N / kt: an arc theta_s ~ 2 sqrt(u_s / U). Where friction matters the
    motion is of the order of the friction force's displacement on the structure,
    U ~ mu N / k, so theta_s ~ 2 sqrt(k / kt). A transition placed one sample (2 pi / ns)
    off moves u by U theta_s 2 pi / ns; against the stick range 2 u_s that is a relative
    error of the hysteresis ~ (2 pi / ns) sqrt(kt / k). It reaches 1, the whole stick arc
    inside two samples (what the laws count as ``undersampled``), at
    kt / k = (ns / 2 pi)^2: above, the results go to the stuck-spring limit (still
    converging) at an accuracy the samples set. k is the structure's stiffness along the
    contact's motion, b K b^T (the other DOFs held: the larger, so no false note)."""
    if "model" not in data or not any(a.get("type") in ("frf", "peak")
                                      for a in data.get("analysis", [])):
        return []
    dofs = data["model"]["dofs"]
    index = {d: i for i, d in enumerate(dofs)}
    K = _as_matrix(data["model"]["stiffness"], len(dofs))
    ns = harmonics(Case(data, "")).n_samples
    limit = (ns / (2 * np.pi)) ** 2
    out = []
    for i, c in enumerate(data.get("contacts", [])):
        if not c.get("enabled", True):
            continue
        name = c.get("name", f"contact{i}")
        d, variable = LAWS[c["law"]]
        kt = np.broadcast_to(np.asarray(c["kt"], dtype=float), (d,))
        springs = [(f"kt{'' if d == 1 else f'[{j}]'}", kt[j], k)
                   for j, k in enumerate(["u"] if d == 1 else ["u1", "u2"])]
        springs += [("kn", c["kn"], "v")] if variable else []
        for key, stiff, motion in springs:
            b = _row(c[motion], index, len(dofs)).real
            k = float(b @ K @ b)
            if k <= 0 or stiff / k <= limit:
                continue
            need = 1 << int(np.ceil(np.log2(2 * np.pi * np.sqrt(stiff / k))))
            out.append(f"contacts.{name}.{key} = {stiff:g} N/m is {stiff / k:.3g} x the "
                       f"structure's stiffness along {motion} ({k:g} N/m), above "
                       f"(samples / 2 pi)^2 = {limit:.0f} for {ns} samples per period: the stick "
                       "arc after a reversal falls inside two samples, so the results tend to "
                       "the stuck-spring limit at an accuracy the sampling sets; "
                       f"harmonics.samples = {need:,} would resolve it")
    return out


# --------------------------------------------------------------- key paths
def _resolve(data, part: str):
    if isinstance(data, list):
        for item in data:
            if isinstance(item, dict) and item.get("name") == part:
                return item
        return data[int(part)]
    return data[part]


def _get_path(data: dict, key: str):
    if not isinstance(key, str) or not key or key.startswith("analysis"):
        raise KeyError(key)
    node = data
    for part in key.split("."):
        node = _resolve(node, part)
    return node


def _set_path(data: dict, key: str, value, create: bool = False) -> None:
    parts = key.split(".")
    node = data
    for part in parts[:-1]:
        node = _resolve(node, part)
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        if last not in node and not create:
            raise KeyError(key)
        node[last] = value


# --------------------------------------------------------------- building
def harmonics(case: Case) -> Harmonics:
    h = case.data.get("harmonics", {})
    orders = h.get("orders", list(range(h.get("max", 1) + 1)))
    return Harmonics(orders, h.get("samples", default_samples(max(orders))))


def settings(case: Case) -> Settings:
    s = {k: v for k, v in case.data.get("solver", {}).items() if k != "sub_sample"}
    return Settings(**s)


def _as_matrix(value, n: int) -> np.ndarray:
    arr = np.array(value, dtype=float)
    return np.diag(arr) if arr.ndim == 1 else arr


def _row(combo: dict, index: dict[str, int], n: int, order: int = 0) -> np.ndarray:
    """Kinematic row at harmonic ``order``: a lag of a fraction of the period
    multiplies harmonic n by exp(-2 pi i n lag)."""
    r = np.zeros(n, dtype=complex)
    for d, coef in combo.items():
        if isinstance(coef, dict):
            r[index[d]] += coef.get("coef", 1.0) * np.exp(-2j * np.pi * order
                                                          * coef.get("lag", 0.0))
        else:
            r[index[d]] += coef
    return r


def contact_elements(c: dict) -> ContactElements:
    """ContactElements of one [[contacts]] table (one point)."""
    coupled = c.get("form", "uncoupled") == "coupled"
    kw = dict(kt=np.atleast_1d(np.array(c["kt"], dtype=float))[None, :], mu=c["mu"],
              coupled=coupled, kn=c.get("kn", 0.0), n_points=1)
    if "interference" in c:
        kw["interference"] = c["interference"]
    else:
        kw["n0"] = c["n0"]
    return ContactElements.create(c["law"], **kw)


def model(case: Case) -> HarmonicBalance:
    """The harmonic-balance model of a lumped case."""
    m = case.data["model"]
    dofs = case.dofs
    n = len(dofs)
    index = {d: i for i, d in enumerate(dofs)}
    h = harmonics(case)
    lin = LinearDynamics.create(
        _as_matrix(m["stiffness"], n), _as_matrix(m["mass"], n),
        _as_matrix(m.get("damping", np.zeros(n)), n), harmonics=h,
        mass_part=_as_matrix(m["mass_part"], n) if "mass_part" in m else None)
    contacts = []
    for i, c in enumerate(case.data.get("contacts", [])):
        if not c.get("enabled", True):
            continue
        el = contact_elements(c)
        keys = ["u"] if el.dim == 1 else ["u1", "u2"]
        if el.variable_normal:
            keys.append("v")
        if _has_lag({"contacts": [c]}):
            B = {o: np.array([_row(c[k], index, n, o) for k in keys]) for o in h.orders}
        else:
            B = np.array([_row(c[k], index, n).real for k in keys])
        contacts.append(Contact(c.get("name", f"contact{i}"), el, B))
    forces: dict[int, np.ndarray] = {}
    for load in case.data.get("loads", []):
        o = load.get("harmonic", 1)
        f = forces.setdefault(o, np.zeros(n, dtype=complex))
        f[index[load["dof"]]] += load["amplitude"] * np.exp(1j * np.deg2rad(load.get("phase",
                                                                                     0.0)))
    sub = case.data.get("solver", {}).get("sub_sample", True)
    return HarmonicBalance(lin, contacts, Excitation(forces), h, sub_sample=sub)


def operating_point(analysis: dict, case: Case | None = None) -> OperatingPoint:
    """The fixed values of the parameters an analysis does not sweep (a coupled case's
    damper mass multiplier and excitation multiplier from [coupling] mass_multiplier and
    excitation)."""
    par = analysis.get("parameter", "frequency")
    omega = analysis["start"] if par == "frequency" else analysis["frequency"]
    table = {} if case is None else case.data.get("coupling", {})
    return OperatingPoint(float(omega), excitation=float(table.get("excitation", 1.0)),
                          mass_multiplier=float(table.get("mass_multiplier", 1.0)))


def curve_variants(case: Case, a: dict) -> list[tuple[Case, str, object]]:
    """(case variant, label, family value) per curve of an analysis: its ``set`` applied,
    then each family value or table."""
    case = case.with_values(a.get("set", {}))
    fam = a.get("family")
    if not fam:
        return [(case, "", None)]
    if "sets" in fam:
        return [(case.with_values(s), str(v), v) for v, s in zip(fam["values"], fam["sets"])]
    label = fam.get("label", fam["key"])
    return [(case.with_value(fam["key"], v), _value_label(label, v), v) for v in fam["values"]]


def _value_label(label: str, v: float) -> str:
    """("N0 [N]", 0.02) -> "N0 = 0.02 N": a legend reads the value with its unit."""
    name, _, unit = label.partition(" [")
    unit = unit.removesuffix("]")
    return f"{name} = {v:g}" + (f" {unit}" if unit not in ("", "-") else "")
