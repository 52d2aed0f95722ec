"""`run --dry-run`'s time estimates against measured runs of the shipped cases: within the
factor the README states (2x), once scaled by the machine's speed now (a reference sweep timed
in the same process: a busy machine is slower, not the estimate wrong)."""

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from microslip import case as cases
from microslip.app import plan
from microslip.app.cache import SharedCache
from microslip.app.run import run_case
from microslip.laws import kernels_cached, warm_up

CASES = Path(__file__).parents[1] / "cases"
#: The README's promise: a run takes between half and twice its estimate.
FACTOR = 2.0


def _estimate(path: Path, out: Path, shared: SharedCache, start: bool) -> float:
    stages = plan.plan(cases.load(path), out, shared=shared)
    return sum(s.seconds for s in stages
               if not s.cached and (start or not s.name.startswith("start")))


def test_the_estimate_of_a_quick_case_holds(tmp_path):
    """The Duffing case in this process (no start to pay): measured against the estimate."""
    if not kernels_cached():
        warm_up(lambda m: None)
    shared = SharedCache(tmp_path / "cache")
    estimate = _estimate(CASES / "05_duffing.toml", tmp_path / "o", shared, start=False)
    factor = plan.machine_factor()
    t = time.perf_counter()
    run_case(cases.load(CASES / "05_duffing.toml"), tmp_path / "o", progress=lambda m: None,
             shared=shared)
    ratio = (time.perf_counter() - t) / (estimate * factor)
    # at the factor's floor (0.5: this machine runs the reference sweep faster than that
    # over its anchor, as the compiled kernels now do on two quiet cores) the machine's speed
    # is known only as "at least this fast", so only the upper bound holds there
    low = 1 / FACTOR if factor > plan.FACTOR_FLOOR else 0.0
    assert low <= ratio <= FACTOR, (ratio, estimate, factor)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["01_sdof_wall", "03_normal_load", "06_blade_damper",
                                  "11_blisk_quick", "12_shrouded_blisk"])
def test_the_estimates_of_the_shipped_cases_hold(name, tmp_path):
    """Each case cold (an empty cache, a new folder) by the command, as a user runs it."""
    env = {**os.environ, "MICROSLIP_CACHE": str(tmp_path / "cache")}
    shared = SharedCache(tmp_path / "cache")
    estimate = _estimate(CASES / f"{name}.toml", tmp_path / "o", shared, start=True)
    factor = plan.machine_factor()
    for p in shared.files():  # the plan meshed: the run meshes again, as a cold run does
        p.unlink()
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "microslip.cli", "run",
                    str(CASES / f"{name}.toml"), "--out", str(tmp_path / "o"), "--workers",
                    "0"], check=True, env=env, capture_output=True)
    ratio = (time.perf_counter() - t) / (estimate * factor)
    assert 1 / FACTOR <= ratio <= FACTOR, (ratio, estimate, factor)
