"""Models from a validated lumped case: the harmonics, the solver settings, each contact's
elements and kinematic rows (the reference text's eqs. 21-23), the harmonic-balance model,
the operating point and the case as each curve of an analysis sees it."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from microslip.fourier import Harmonics
from microslip.laws.interface import ContactSet
from microslip.laws.registry import LAWS
from microslip.solve.continuation import Settings
from microslip.solve.hbm import Contact, HarmonicBalance
from microslip.solve.linear import Excitation, LinearDynamics, OperatingPoint

from . import specs
from .faults import has_lag
from .paths import parameter_keys

if TYPE_CHECKING:
    from .validated import Case


def harmonics(case: Case) -> Harmonics:
    """The harmonics of a case: orders 0..max or the orders given, and its samples."""
    return harmonics_of(case.data)


def harmonics_of(data: Mapping[str, Any]) -> Harmonics:
    """The harmonics of a case table (see :func:`harmonics`)."""
    return specs.HarmonicsTable.of(data.get("harmonics", {})).harmonics()


def settings(case: Case) -> Settings:
    """The continuation settings of a case ([solver])."""
    return case.solver_table.settings


def as_matrix(value, n: int) -> np.ndarray:
    arr = np.array(value, dtype=float)
    return np.diag(arr) if arr.ndim == 1 else arr


def kinematic_row(combo: dict, index: dict[str, int], n: int, order: int = 0) -> np.ndarray:
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


def contact_elements(table: Mapping[str, Any]) -> ContactSet:
    """The contact set of one [[contacts]] table (one point), built by its law."""
    return LAWS[table["law"]].elements(table)


def lumped_model(case: Case) -> HarmonicBalance:
    """The harmonic-balance model of a lumped case."""
    m = case.data["model"]
    dofs = case.dofs
    n = len(dofs)
    index = {d: i for i, d in enumerate(dofs)}
    h = harmonics(case)
    lin = LinearDynamics.create(
        as_matrix(m["stiffness"], n), as_matrix(m["mass"], n),
        as_matrix(m.get("damping", np.zeros(n)), n), harmonics=h,
        mass_part=as_matrix(m["mass_part"], n) if "mass_part" in m else None)
    contacts = []
    for i, c in enumerate(case.data.get("contacts", [])):
        contact = specs.ContactTable.of(c, i)
        if not contact.enabled:
            continue
        el = contact_elements(c)
        keys = LAWS[c["law"]].motions
        if has_lag({"contacts": [c]}):
            B = {o: np.array([kinematic_row(c[k], index, n, o) for k in keys]) for o in h.orders}
        else:
            B = np.array([kinematic_row(c[k], index, n).real for k in keys])
        contacts.append(Contact(contact.name, el, B))
    forces: dict[int, np.ndarray] = {}
    for table in case.data.get("loads", []):
        load = specs.LoadTable.of(table)
        o = load.harmonic
        f = forces.setdefault(o, np.zeros(n, dtype=complex))
        f[index[load.dof]] += load.amplitude * np.exp(1j * np.deg2rad(load.phase))
    solver = case.solver_table
    return HarmonicBalance(lin, contacts, Excitation(forces), h, sub_sample=solver.sub_sample,
                           jacobian=solver.jacobian)


def operating_point(case: Case | None = None, omega: float = 1.0) -> OperatingPoint:
    """The operating point at frequency ``omega`` (rad/s) with the fixed values of the other
    parameters: an assembly case's damper mass multiplier and excitation multiplier from
    [assembly] mass_multiplier and excitation (1 elsewhere)."""
    table = {} if case is None else case.data.get("assembly", {})
    return OperatingPoint(float(omega), excitation=float(table.get("excitation", 1.0)),
                          mass_multiplier=float(table.get("mass_multiplier", 1.0)))


def curve_variants(case: Case, spec: specs.Analysis) -> list[tuple[Case, str, Any]]:
    """(case variant, label, family value) per curve of an analysis: its ``set`` applied,
    then each family value or table."""
    case = case.with_values(spec.set)
    family = getattr(spec, "family", None)
    if family is None:
        return [(case, "", None)]
    if family.sets:
        return [(case.with_values(s), str(v), v) for v, s in zip(family.values, family.sets)]
    return [(case.with_value(family.key, v), _value_label(family.legend, v), v)
            for v in family.values]


def sample_variants(case: Case, spec: specs.Analysis) -> tuple[list[str], np.ndarray,
                                                                  list[dict[str, Any]]]:
    """(names, (samples, p) values of the uncertain parameters, per sample the case keys
    it sets: the analysis' ``set``, the fixed parameters, its values)."""
    names, x = spec.sample_values()
    common = dict(spec.set)
    for k, v in spec.fixed().items():
        common |= dict.fromkeys(parameter_keys(case.data, k), v)
    out = []
    for row in x:
        keys = dict(common)
        for k, v in zip(names, row):
            keys |= dict.fromkeys(parameter_keys(case.data, k), float(v))
        out.append(keys)
    return names, x, out


def _value_label(label: str, v: float) -> str:
    """("N0 [N]", 0.02) -> "N0 = 0.02 N": a legend reads the value with its unit."""
    name, _, unit = label.partition(" [")
    unit = unit.removesuffix("]")
    return f"{name} = {v:g}" + (f" {unit}" if unit not in ("", "-") else "")
