"""Case-file helpers shared by the tests."""

import copy

import pytest

from microslip import case as cases

#: A valid lumped case: 2 DOFs, one law-B contact (variable normal load), one FRF
TWO_DOF = {
    "title": "t",
    "model": {"dofs": ["x", "y"], "mass": [1.0, 2.0], "stiffness": [[2.0, -1.0], [-1.0, 2.0]],
              "damping": [0.01, 0.01]},
    "contacts": [{"name": "c", "law": "B", "kt": 1.0, "kn": 2.0, "mu": 0.3, "n0": 0.5,
                  "u": {"x": 1.0}, "v": {"y": 1.0, "x": -0.5}}],
    "loads": [{"dof": "x", "amplitude": 0.1, "harmonic": 1}],
    "harmonics": {"max": 3, "samples": 64},
    "analysis": [{"name": "a", "type": "frf", "start": 0.5, "stop": 2.0}],
}


def case_faults(good: dict, mutate) -> list[str]:
    """The faults ``check`` reports for a copy of ``good`` changed by ``mutate`` (it must
    report some)."""
    data = copy.deepcopy(good)
    mutate(data)
    with pytest.raises(cases.CaseError) as err:
        cases.check(data)
    return err.value.faults
