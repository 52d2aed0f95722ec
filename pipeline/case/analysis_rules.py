"""The rules several analysis types share (their kinds' ``check`` calls them): a
continuation's parameter and range, a family of curves, switches, measures, outputs, a
frequency window, what time integration cannot take, contact maps, and an uncertainty
study's distributions. Each appends one line per fault to the ``Checking``'s lines."""

from __future__ import annotations

import dataclasses

from microslip.laws.coulomb import FrictionLaw
from microslip.laws.registry import LAWS

from . import specs
from .checks import is_int, is_number, number, unknown_keys
from .faults import has_lag, overrides_faults
from .kinds import Checking
from .paths import get_path, parameter_keys

FAMILY_KEYS = {f.name for f in dataclasses.fields(specs.Family)}


def sweep_range(c: Checking, allowed: tuple[str, ...]) -> bool:
    """A continuation parameter among ``allowed`` and its range (start, stop); whether both
    ends are numbers."""
    a, pre = c.table, c.pre
    par = a.get("parameter")
    if par not in allowed:
        c.out.append(f"{pre}.parameter = {par!r}: expected one of {list(allowed)}")
    ok = all(number(f"{pre}.{k}", a.get(k), c.out) for k in ("start", "stop"))
    if ok and a["start"] == a["stop"]:
        c.out.append(f"{pre}: start = stop = {a['start']}: the range has zero length")
    if ok and (par == "frequency" or par == "mass") and min(a["start"], a["stop"]) <= 0:
        c.out.append(f"{pre}: {par} range {a['start']}..{a['stop']} must be > 0")
    return ok


def family_faults(c: Checking) -> None:
    """A ``family`` (one curve per value of a key, or per table of overrides), if given."""
    if c.table.get("family") is not None:
        _family(c.pre, c.table["family"], c.data, c.out)


def flag(c: Checking, key: str, meaning: str) -> None:
    """``key`` is true or false (``meaning``: what true does)."""
    if not isinstance(c.table[key], bool):
        c.out.append(f"{c.pre}.{key} = {c.table[key]!r}: expected true or false{meaning}")


def measure_faults(c: Checking, allowed: tuple[str, ...]) -> None:
    """``measure`` among ``allowed`` response measures."""
    m = c.table["measure"]
    if m not in allowed:
        c.out.append(f"{c.pre}.measure = {m!r}: expected "
                     + (" or ".join(f"'{x}'" for x in allowed) if len(allowed) == 2
                        else f"one of {list(allowed)}"))


def output_faults(c: Checking) -> None:
    """Each of ``outputs`` a DOF of the model."""
    for o in c.table.get("outputs", []):
        if o not in c.outputs:
            c.out.append(f"{c.pre}.outputs: {o!r} is not a DOF; known: {sorted(c.outputs)}")


def output_fault(c: Checking, what: str = "DOF") -> None:
    """``output`` one of the case's outputs (``what`` they are called in the line)."""
    if c.table.get("output") not in c.outputs:
        c.out.append(f"{c.pre}.output = {c.table.get('output')!r}: unknown {what}; known: "
                     f"{sorted(c.outputs)}")


def sector_only(c: Checking) -> None:
    """An analysis that follows one response: not on the whole disk ([assembly.mistuning]),
    where each output is one per blade."""
    if isinstance((c.data.get("assembly") or {}).get("mistuning"), dict):
        c.out.append(f"{c.pre}: follows one response, and [assembly.mistuning] makes every "
                     "output one per blade; on the whole disk use frf (every blade) or "
                     "mistuning (the worst blade over patterns)")


def window_faults(c: Checking) -> None:
    """``window`` = [w_low, w_high], 0 < w_low < w_high (rad/s)."""
    _window(c.pre, c.table.get("window"), c.out)


def time_integration_faults(c: Checking) -> None:
    """What time integration cannot take: a delayed DOF (a contact's ``lag``)."""
    if has_lag(c.data):
        c.out.append(f"{c.pre}: time integration cannot delay a DOF (a contact kinematics "
                     "with 'lag'); use harmonic balance")


def friction_laws_only(c: Checking) -> None:
    """Time integration takes the friction laws A-D only, not the benchmark springs."""
    springs = sorted({x.get("law") for x in c.data.get("contacts", []) if isinstance(x, dict)
                      and not isinstance(LAWS.get(x.get("law")), (FrictionLaw, type(None)))})
    if springs:
        c.out.append(f"{c.pre}: time integration takes the friction laws A-D only; the case "
                     f"has {springs} (use harmonic balance)")


def uncertainty_faults(c: Checking) -> None:
    """An uncertainty study's keys and distributions, and the case at the smallest and the
    largest value each parameter takes over the samples."""
    _uncertainty(c.pre, c.table, c.data, set(c.outputs), c.out)


#: The largest sample count of an uncertainty study.
MAX_SAMPLES = 1_000_000


def _window(pre: str, w, out: list[str]) -> None:
    if not (isinstance(w, list) and len(w) == 2 and all(
            isinstance(x, (int, float)) and x > 0 for x in w) and w[0] < w[1]):
        out.append(f"{pre}.window = {w!r}: expected [w_low, w_high] in rad/s, "
                   "0 < w_low < w_high")


def _uncertainty(pre: str, a: dict, data: dict, dofs: set[str], out: list[str]) -> None:
    """An uncertainty study's keys, its distributions, and the case at the smallest and at
    the largest value each parameter takes over the samples (what a sample could break)."""
    from microslip.solve.sampling import DESIGNS, FAMILIES, design

    _window(pre, a.get("window"), out)
    if a.get("output") not in dofs:
        out.append(f"{pre}.output = {a.get('output')!r}: unknown output; known: "
                   f"{sorted(dofs)}")
    n = a["samples"]
    if not (is_int(n) and 2 <= n <= MAX_SAMPLES):
        out.append(f"{pre}.samples = {n!r}: expected an integer from 2 to {MAX_SAMPLES}")
    if a["design"] not in DESIGNS:
        out.append(f"{pre}.design = {a['design']!r}: expected one of {list(DESIGNS)}")
    elif a["design"] == "sobol" and is_int(n) and n & (n - 1):
        out.append(f"{pre}.samples = {n}: a Sobol' design needs a power of 2 (its balance: "
                   f"{1 << (n - 1).bit_length() >> 1} or {1 << (n - 1).bit_length()}), or "
                   "design = 'lhs'")
    if not (is_int(a["seed"]) and a["seed"] >= 0):
        out.append(f"{pre}.seed = {a['seed']!r}: expected an integer >= 0")
    if a.get("limit") is not None:
        number(f"{pre}.limit", a["limit"], out, positive=True)
    pars = a.get("parameters")
    if not (isinstance(pars, dict) and pars):
        out.append(f"{pre}.parameters = {pars!r}: expected a table of name = distribution "
                   "or value, e.g. {{ mu = {{ uniform = [0.3, 0.8] }} }}")
        return
    before = len(out)
    dists = {}
    for name, v in pars.items():
        where = f"{pre}.parameters.{name}"
        if "." not in name and not parameter_keys(data, name):
            out.append(f"{where}: a plain name is that key of every contact, and the case has "
                       "no contacts; give a dotted case key")
        elif is_number(v):
            continue
        elif not (isinstance(v, dict) and len(v) == 1 and next(iter(v)) in FAMILIES):
            out.append(f"{where} = {v!r}: expected a value or one of " + ", ".join(
                f"{{{k} = {rule}}}" for k, rule in FAMILIES.items()))
        elif _distribution(where, *next(iter(v.items())), out):
            dists[name] = specs.distribution(v)
    if len(out) > before or not dists or not (is_int(n) and 2 <= n <= MAX_SAMPLES) \
            or a["design"] not in DESIGNS or not is_int(a["seed"]):
        return
    x = design(list(dists.values()), n, a["design"], a["seed"])
    fixed = {k: v for k, v in pars.items() if k not in dists}
    for side, values in (("smallest", x.min(axis=0)), ("largest", x.max(axis=0))):
        table = dict(a.get("set") or {})
        for k, v in {**fixed, **dict(zip(dists, values.tolist()))}.items():
            table |= dict.fromkeys(parameter_keys(data, k), v)
        found: list[str] = []
        overrides_faults(f"{pre}.parameters at their {side} sampled values", data, table, found)
        out.extend(found[:1])  # one line: the first rule the samples break


def _distribution(where: str, family: str, v, out: list[str]) -> bool:
    """Whether one parameter's ``{family = v}`` is well formed (else one fault)."""
    if family == "uniform":
        if not (isinstance(v, list) and len(v) == 2 and all(is_number(x) for x in v)
                and v[0] < v[1]):
            out.append(f"{where}.uniform = {v!r}: expected [low, high], low < high")
            return False
        return True
    first = "mean" if family == "normal" else "median"
    if not (isinstance(v, dict) and set(v) == {first, "sigma"}):
        out.append(f"{where}.{family} = {v!r}: expected {{{first} = ..., sigma = ...}}")
        return False
    ok = number(f"{where}.{family}.{first}", v[first], out, positive=family == "lognormal")
    return number(f"{where}.{family}.sigma", v["sigma"], out, positive=True) and ok


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
            overrides_faults(f"{pre}.family.sets[{j}]", data, table, out)
        return
    key = fam.get("key")
    try:
        get_path(data, key)
    except (KeyError, IndexError, TypeError, ValueError):
        out.append(f"{pre}.family.key = {key!r}: no such key in the case (use e.g. "
                   "'contacts.<name>.n0' or 'loads.0.amplitude')")
        return
    if key.startswith("harmonics."):  # each value moves H or the samples: the same rule
        for j, v in enumerate(vals):
            overrides_faults(f"{pre}.family.values[{j}]", data, {key: v}, out)
