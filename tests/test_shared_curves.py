"""A curve computed once and asked for by two analyses (the store is keyed by what a curve
computes): each analysis stores it under its own identity, as a run without the store does."""

from pathlib import Path

import h5py

from microslip.cli import main

CASES = Path(__file__).parents[1] / "cases"
#: sdof_wall's model (Fig. 4-6), where frf_force's F = 0.1 N curve is frf_N0's N0 = 0.05 N
#: one, and the performance curve's value 1 is the optimization curve's value 0.05; its
#: period sampled more coarsely, its steps longer (quick; the sharing is what is tested).
CASE = (CASES / "01_sdof_wall.toml").read_text().split("[[analysis]]")[0].replace(
    "samples = 256", "samples = 64") + """
[solver]
max_step = 0.2
[[analysis]]
name = "frf_N0"
type = "frf"
start = 0.5
stop = 2.5
family = { key = "contacts.wall.n0", values = [0.02, 0.05], label = "N0 [N]" }
[[analysis]]
name = "frf_force"
type = "frf"
start = 0.5
stop = 2.5
set = { "contacts.wall.n0" = 0.05 }
family = { key = "loads.0.amplitude", values = [0.1, 0.2], label = "F [N]" }
[[analysis]]
name = "optimization"
type = "peak"
parameter = "preload"
start = 0.05
stop = 0.1
window = [0.5, 2.5]
output = "x"
points = 2
[[analysis]]
name = "optimization_again"
type = "peak"
parameter = "preload"
start = 0.05
stop = 0.1
window = [0.5, 2.5]
output = "x"
points = 2
family = { key = "loads.0.amplitude", values = [0.1], label = "F [N]" }
"""


def _attributes(path) -> dict:
    """Every attribute of every group of a results file but those of the run's record
    (when, how long, from which cache)."""
    skip = {"created", "versions", "elapsed_s", "source", "cached"}
    out = {}

    def visit(name, obj):
        for k, v in obj.attrs.items():
            if k not in skip:
                out[name, k] = v.tolist() if hasattr(v, "tolist") else v

    with h5py.File(path, "r") as f:
        f.visititems(visit)
    return out


def test_a_shared_curve_takes_the_identity_of_the_analysis_asking(tmp_path, capsys):
    case = tmp_path / "shared.toml"
    case.write_text(CASE)
    cached, fresh = tmp_path / "cached", tmp_path / "fresh"
    assert main(["run", str(case), "--out", str(cached), "--workers", "0"]) == 0
    out = capsys.readouterr().out
    assert "from the cache" in out  # the shared curves were shared within the first run
    assert main(["run", str(case), "--out", str(fresh), "--workers", "0", "--no-cache"]) == 0
    with h5py.File(cached / "results.h5", "r") as f:
        force = f["frf_force"]["curve_000"].attrs
        assert force["label"] == "F = 0.1 N"
        assert force["family_key"] == "loads.0.amplitude" and force["family_value"] == 0.1
        again = f["optimization_again"]["curve_000"].attrs
        assert again["label"] == "F = 0.1 N"
    assert _attributes(cached / "results.h5") == _attributes(fresh / "results.h5")
    capsys.readouterr()
    assert main(["compare", str(fresh), str(cached)]) == 0, capsys.readouterr().out
