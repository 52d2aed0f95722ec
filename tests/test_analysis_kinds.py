"""An analysis type is one module behind one interface (``case.kinds.AnalysisKind``): a
type defined here, outside the package, goes through check, run, the dry run and render by
joining the shipped kinds, and nothing of the package is edited for it."""

import copy
from dataclasses import dataclass
from typing import ClassVar

import h5py
import matplotlib
import numpy as np
import pytest
import scipy.linalg as sla

from microslip.app import plan
from microslip.app.analyses import KINDS
from microslip.app.run import run_case
from microslip.case import Case, CaseError, check
from microslip.case.kinds import AnalysisKind, Checking, shipped
from microslip.case.specs import Analysis
from microslip.draw.pictures import render

matplotlib.use("Agg")


@dataclass(frozen=True, kw_only=True)
class Natural(Analysis):
    """The lowest ``count`` undamped natural frequencies of a lumped model."""

    type: ClassVar[str] = "natural"
    count: int = 2


def _check(c: Checking) -> None:
    n = len(c.data["model"]["dofs"])
    if not (isinstance(c.table["count"], int) and 1 <= c.table["count"] <= n):
        c.fault(f".count = {c.table['count']!r}: expected an integer in [1, {n}]")


def _run(case: Case, spec: Natural, group: h5py.Group, run) -> tuple[str, str]:
    model = case.with_values(spec.set).data["model"]
    K = np.diag(model["stiffness"]) if np.ndim(model["stiffness"]) == 1 else np.array(
        model["stiffness"], float)
    M = np.diag(model["mass"]) if np.ndim(model["mass"]) == 1 else np.array(model["mass"],
                                                                            float)
    omega = np.sqrt(sla.eigh(K, M, eigvals_only=True)[:spec.count])
    run.writer.write_group(group, "frequencies", {"omega": omega}, {"status": "complete"})
    run.progress(f"[{spec.name}] w = {omega}")
    return "complete", ""


def _draw(g: h5py.Group, name: str, out, options=None) -> list:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.bar(range(len(g["frequencies/omega"])), g["frequencies/omega"][()])
    path = out / f"{name}.png"
    fig.savefig(path)
    plt.close(fig)
    return [path]


TOY = AnalysisKind("natural", Natural, _check, lambda data, spec, variant=None: 0.01,
                   _run, _draw)
KINDS_WITH_TOY = shipped().with_kind(TOY)

# two masses in a chain: k1 = 2, k2 = 1 (x1 to ground, x2 to x1), m = 1, 1
CASE = {"title": "two masses", "model": {"dofs": ["x1", "x2"], "mass": [1.0, 1.0],
                                         "stiffness": [[3.0, -1.0], [-1.0, 1.0]]},
        "analysis": [{"name": "eig", "type": "natural", "count": 2}]}


def test_the_shipped_kinds_are_the_analyses_modules():
    assert shipped() is shipped() and shipped() is KINDS
    assert list(KINDS) == ["frf", "peak", "uncertainty", "mistuning", "loops", "dti", "transient",
                           "modes", "nonlinear_modes"]
    assert all(k.spec.type == name for name, k in KINDS.items())


def test_a_new_kind_is_checked_by_its_own_rules():
    check(copy.deepcopy(CASE), kinds=KINDS_WITH_TOY)  # valid
    bad = copy.deepcopy(CASE)
    bad["analysis"][0]["count"] = 5
    with pytest.raises(CaseError, match=r"analysis\.eig\.count = 5: expected an integer in "
                                        r"\[1, 2\]"):
        check(bad, kinds=KINDS_WITH_TOY)
    bad["analysis"][0]["counts"] = 1  # the common rules: keys its spec does not have
    with pytest.raises(CaseError, match="counts"):
        check(bad, kinds=KINDS_WITH_TOY)
    with pytest.raises(CaseError, match=r"type = 'natural': expected one of \['frf'"):
        check(copy.deepcopy(CASE))  # the shipped kinds do not know it


def test_a_new_kind_runs_plans_and_renders(tmp_path):
    case = Case(copy.deepcopy(CASE), "toy.toml", kinds=KINDS_WITH_TOY)
    said: list[str] = []
    path = run_case(case, tmp_path / "run", progress=said.append)
    # the chain's frequencies in closed form: w^2 = 2 -+ sqrt(2)
    expected = np.sqrt([2 - np.sqrt(2), 2 + np.sqrt(2)])
    with h5py.File(path) as f:
        assert f.attrs["status"] == "complete"
        assert f["eig"].attrs["status"] == "complete" and f["eig"].attrs["type"] == "natural"
        np.testing.assert_allclose(f["eig/frequencies/omega"][()], expected, rtol=1e-12)
    assert any(line.startswith("[eig] natural ...") for line in said)
    stages = plan.plan(case, tmp_path / "run")
    assert [s.name for s in stages][-1] == "eig: natural"  # the generic stage
    assert render(path, tmp_path / "again", kinds=KINDS_WITH_TOY) == [
        tmp_path / "again" / "eig.png"]
    assert render(path, tmp_path / "shipped") == []  # the shipped kinds skip what they
    # do not know
