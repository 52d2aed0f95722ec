"""Case-file helpers shared by the tests."""

import copy

import pytest

from microslip.pipeline.app import case as cs


def case_faults(good: dict, mutate) -> list[str]:
    """The faults ``check`` reports for a copy of ``good`` changed by ``mutate`` (it must
    report some)."""
    data = copy.deepcopy(good)
    mutate(data)
    with pytest.raises(cs.CaseError) as err:
        cs.check(data)
    return err.value.faults
