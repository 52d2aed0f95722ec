"""Validation of a case table: every fault found, one line each, naming the key, the value
and what is allowed (:func:`faults`), before anything is built or computed."""

from __future__ import annotations

import copy
import re

import numpy as np

from microslip import geometry
from microslip.laws.coulomb import FORMS, FrictionLaw
from microslip.laws.registry import LAWS
from microslip.solve.hbm import JACOBIANS

from . import assembly_table, specs
from .checks import is_int, number, samples_rule, unknown_keys
from .geometry_table import check as check_geometry
from .kinds import Checking, Kinds, kinds_or_shipped
from .paths import set_path
from .reduction_table import check as check_reduction
from .reduction_table import names_faults as reduction_names

TOP_KEYS = {"title", "description", "model", "contacts", "loads", "harmonics", "solver",
            "analysis", "geometry", "reduction", "assembly"}
MODEL_KEYS = {"dofs", "mass", "stiffness", "damping", "mass_part"}
CONTACT_KEYS = {"name", "law", "form", "kt", "kn", "mu", "n0", "interference", "u", "u1", "u2",
                "v", "enabled"}
LOAD_KEYS = {"dof", "amplitude", "harmonic", "phase"}
HARMONIC_KEYS = {"max", "orders", "samples"}
SOLVER_KEYS = {"tol", "max_iter", "step", "min_step", "max_step", "max_turn", "target_iter",
               "max_points", "sub_sample", "jacobian"}


def faults(data: dict, out: list[str], analyses: bool = True, kinds: Kinds | None = None
           ) -> None:
    """Append one line per fault of a case table to ``out`` (the analyses too with
    ``analyses``, each by its type's rules: ``kinds``, default the shipped ones)."""
    unknown_keys("", data, TOP_KEYS, out)
    table = None
    if "geometry" in data:  # (load made an imported file's path absolute)
        table = check_geometry(data["geometry"], ".", out)
    if "reduction" in data:
        before = len(out)
        check_reduction(data["reduction"], data, out, table)
        if table is not None and table.imported and len(out) == before:
            reduction_names(table.build(), data["reduction"], out)  # read once, kept
    if "assembly" in data:
        _check_assembly(data, out, analyses, _names(table), kinds_or_shipped(kinds))
        return
    if "geometry" in data and "model" not in data and "analysis" not in data:
        _harmonics(data.get("harmonics", {}), out)  # the NDs of an engine order use them
        return  # a mesh (and reduction) case
    if "reduction" in data and "model" not in data:  # reduced bodies on their own: modes
        _harmonics(data.get("harmonics", {}), out)
        known = kinds_or_shipped(kinds)
        bodies = [k for k, kind in known.items() if kind.bodies]
        for i, a in _tables_of(data, bodies, "a case of reduced bodies without [assembly]",
                               out):
            _analysis(i, a, data, set(), set(), out, known)
        return
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
    h = data.get("harmonics", {})
    _loads_computed(data.get("loads", []), "loads", h, _harmonics(h, out), out)
    _solver(data.get("solver", {}), out)
    if analyses:
        known = kinds_or_shipped(kinds)
        for i, a in _analysis_tables(data, tuple(k for k in known if known[k].lumped), out):
            _analysis(i, a, data, seen, names, out, known)


#: Top-level groups of results.h5 that are not analyses (``results.schema``'s, which this
#: stage does not import; a test holds them equal): an analysis may not take their name.
RESERVED = ("case", "geometry", "contact_grids", "surfaces", "reduction")
#: An analysis name: its results.h5 group and the start of its pictures' file names.
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")


def _analysis_tables(data: dict, kinds: tuple[str, ...], out: list[str]) -> list:
    """(index, table) of the case's [[analysis]], or a fault if there is none; a fault per
    name that is taken twice, reserved or not a file name."""
    items = data.get("analysis", [])
    if not isinstance(items, list) or not items:
        out.append(f"analysis: missing; add at least one [[analysis]] with type in "
                   f"{list(kinds)}")
        return []
    seen: dict[str, int] = {}
    for i, a in enumerate(items):
        if not isinstance(a, dict):
            continue
        name = a.get("name", specs.analysis_name(a, i))
        if not (isinstance(name, str) and NAME.fullmatch(name)):
            out.append(f"analysis[{i}].name = {name!r}: expected letters, digits, '_', '-' "
                       "or '.', starting with a letter or digit (it names the analysis' "
                       "results group and pictures)")
        elif name in RESERVED:
            out.append(f"analysis[{i}].name = {name!r}: reserved for the results file's "
                       f"{name} group; names taken: {list(RESERVED)}")
        elif name in seen:
            out.append(f"analysis[{i}].name = {name!r}: analysis[{seen[name]}] has that name "
                       "already; each analysis needs its own")
        else:
            seen[name] = i
    return list(enumerate(items))


def _tables_of(data: dict, runs: list[str], case: str, out: list[str]) -> list:
    """(index, table) of the [[analysis]] tables of a type this shape of ``case`` runs
    (``runs``); a fault for each of another type."""
    kept = []
    for i, a in _analysis_tables(data, tuple(runs), out):
        if isinstance(a, dict) and a.get("type") not in runs:
            out.append(f"analysis.{a.get('name', i)}.type = {a.get('type')!r}: {case} runs "
                       f"{runs}")
            continue
        kept.append((i, a))
    return kept


def _names(table) -> dict | None:
    """The contacts, bodies and node sets a valid [geometry] gives before any meshing (an
    import's mesh, read at the check; a parametric model's names and declared contacts)."""
    if table is None:
        return None
    if table.imported:
        return assembly_table.names_of(table.build())
    names = geometry.NAMES.get(table.model)
    if names is None:
        return None
    return {**names, "patches": (*names["patches"], *(c.name for c in table.contacts))}


def _check_assembly(data: dict, out: list[str], analyses: bool, names: dict | None,
                    kinds: Kinds) -> None:
    """A case of reduced FE bodies joined by friction patches ([assembly])."""
    assembly_table.check(data["assembly"], data, out, names)
    for key in ("contacts", "loads"):
        if key in data:
            out.append(f"{key}: an assembly case gives its contacts and loads in [assembly]")
    h = data.get("harmonics", {})
    orders = _harmonics(h, out)
    if isinstance(data["assembly"], dict):
        _loads_computed(data["assembly"].get("loads", []), "assembly.loads", h, orders, out)
    _solver(data.get("solver", {}), out)
    if not analyses:
        return
    outputs = set(assembly_table.output_names(data))
    runs = [k for k, kind in kinds.items() if kind.assembly]
    for i, a in _tables_of(data, runs, "an assembly case", out):
        par = a.get("parameter", specs.defaults(kinds[a["type"]].spec).get("parameter")) \
            if isinstance(a, dict) else None
        if par is not None and par not in assembly_table.PARAMETERS:
            out.append(f"analysis.{a.get('name', i)}.parameter = {a.get('parameter')!r}: an "
                       f"assembly case sweeps {list(assembly_table.PARAMETERS)}")
            continue
        _analysis(i, a, data, set(), outputs, out, kinds)


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


def has_lag(data: dict) -> bool:
    return any(isinstance(coef, dict) for c in data.get("contacts", [])
               for k in ("u", "u1", "u2", "v") if isinstance(c.get(k), dict)
               for coef in c[k].values())


def _contact(i: int, c, dofs: set[str], seen: set[str], out: list[str]) -> None:
    pre = f"contacts[{i}]"
    if not isinstance(c, dict):
        out.append(f"{pre}: expected a table")
        return
    name = specs.ContactTable.of(c, i).name
    pre = f"contacts.{name}"
    if name in seen:
        out.append(f"{pre}: duplicate contact name")
    seen.add(name)
    law = LAWS.get(c.get("law")) if isinstance(c.get("law"), str) else None
    if not isinstance(law, FrictionLaw) and law is not None:  # a law of the registry
        unknown_keys(pre + ".", c, {"name", "law", "enabled", *law.motions, *law.parameters,
                                    *getattr(law, "keys", ())}, out)
        for key in law.parameters:
            number(f"{pre}.{key}", c.get(key), out)
        if hasattr(law, "check"):  # the law's own rules (structured keys, ranges)
            law.check(pre, c, out)
        for key in law.motions:
            if key not in c:
                out.append(f"{pre}.{key}: missing (relative displacement as "
                           "{dof = coefficient})")
            else:
                _combination(f"{pre}.{key}", c[key], dofs, out)
        _enabled(pre, c, out)
        return
    unknown_keys(pre + ".", c, CONTACT_KEYS, out)
    if law is None:
        out.append(f"{pre}.law = {c.get('law')!r}: expected one of {sorted(LAWS)}")
        return
    _friction_contact(pre, c, law, dofs, out)


def _enabled(pre: str, c: dict, out: list[str]) -> None:
    if "enabled" in c and not isinstance(c["enabled"], bool):
        out.append(f"{pre}.enabled = {c['enabled']!r}: expected true or false")


def _friction_contact(pre: str, c: dict, friction: FrictionLaw, dofs: set[str],
                      out: list[str]) -> None:
    """The keys of a friction law's contact (laws A-D)."""
    law, d, variable = friction.name, friction.dim, friction.variable_normal
    form = c.get("form", FORMS[0])
    if form not in FORMS:
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
    _enabled(pre, c, out)
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
    number(f"{pre}.harmonic", load.get("harmonic", specs.LoadTable.harmonic), out,
           nonneg=True, integer=True)
    number(f"{pre}.phase", load.get("phase", specs.LoadTable.phase), out)


def _harmonics(h, out: list[str]) -> tuple[int, ...] | None:
    """The faults of [harmonics]; the orders it computes (None when it has a fault)."""
    before = len(out)
    unknown_keys("harmonics.", h, HARMONIC_KEYS, out)
    if not isinstance(h, dict):
        return None
    if "max" in h and "orders" in h:
        out.append("harmonics: give either 'max' (orders 0..max) or 'orders', not both")
    if "max" in h:
        number("harmonics.max", h["max"], out, nonneg=True, integer=True)
    top = h.get("max", specs.HarmonicsTable.max)
    if "orders" in h:
        o = h["orders"]
        if not (isinstance(o, list) and o and all(isinstance(x, int) and x >= 0 for x in o)):
            out.append(f"harmonics.orders = {o!r}: expected a list of integers >= 0")
            return None
        top = max(o)
    if "samples" in h and is_int(top) and top >= 0:
        samples_rule("harmonics.samples", h["samples"], top, out)
    if len(out) > before:
        return None
    return specs.HarmonicsTable.of(h).all_orders


def _loads_computed(loads, where: str, h: dict, orders: tuple[int, ...] | None,
                    out: list[str]) -> None:
    """A fault per load on a harmonic the balance does not compute: its response would be
    zero, and the run 'complete'."""
    if orders is None or not isinstance(loads, list):
        return
    given = (f"harmonics.orders = {list(orders)}" if "orders" in h
             else f"harmonics.max = {max(orders)}: orders {list(orders)}")
    for i, ld in enumerate(loads):
        n = ld.get("harmonic", specs.LoadTable.harmonic) if isinstance(ld, dict) else None
        if is_int(n) and n >= 0 and n not in orders:
            fix = (f"add {n} to harmonics.orders" if "orders" in h
                   else f"raise harmonics.max to {n}")
            out.append(f"{where}[{i}].harmonic = {n}: that order is not computed ({given}), "
                       f"so the load would drive nothing; {fix}")


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
    if "jacobian" in s and s["jacobian"] not in JACOBIANS:
        out.append(f"solver.jacobian = {s['jacobian']!r}: expected one of "
                   f"{', '.join(repr(j) for j in JACOBIANS)}")


def _analysis(i: int, a, data: dict, contacts: set[str], outputs: set[str],
              out: list[str], kinds: Kinds) -> None:
    """The rules every analysis table keeps (a table, a known type, known keys, overrides
    that break nothing), then its type's own (``AnalysisKind.check``)."""
    pre = f"analysis[{i}]"
    if not isinstance(a, dict):
        out.append(f"{pre}: expected a table")
        return
    kind = a.get("type")
    if kind not in kinds:
        out.append(f"{pre}.type = {kind!r}: expected one of {list(kinds)}")
        return
    pre = f"analysis.{a.get('name', i)}"
    cls = kinds[kind].spec
    unknown_keys(pre + ".", a, specs.keys(cls), out)
    given, a = a, specs.defaults(cls) | a  # every default from the spec
    if not isinstance(a.get("figure", ""), str):
        out.append(f"{pre}.figure = {a['figure']!r}: expected text (the reference text's "
                   "figure the analysis reproduces, e.g. \"Fig. 5\")")
    overrides = a.get("set", {})
    if not isinstance(overrides, dict):
        out.append(f"{pre}.set: expected a table {{\"key.path\" = value}}")
    else:
        overrides_faults(f"{pre}.set", data, overrides, out)
    kinds[kind].check(Checking(pre, a, given, data, frozenset(contacts), frozenset(outputs),
                               out))


def overrides_faults(pre: str, data: dict, table: dict, out: list[str]) -> None:
    """Apply overrides to a copy and validate it: a key may be new (e.g.
    ``contacts.x.enabled``) if its table exists; what it breaks is reported."""
    if not table:
        return
    trial = copy.deepcopy({k: v for k, v in data.items() if k != "analysis"})
    base: list[str] = []
    faults(trial, base, analyses=False)
    for key, value in table.items():
        try:
            set_path(trial, key, value, create=True)
        except (KeyError, IndexError, TypeError, ValueError):
            out.append(f"{pre}.{key}: no such table in the case")
            return
    found: list[str] = []
    faults(trial, found, analyses=False)
    out.extend(f"{pre}: {f}" for f in found if f not in base)  # only what the overrides break
