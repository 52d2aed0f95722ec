"""`microslip bench trade`: the settings become valid cases of the blisk-damper study, the
changes are measured against the first (finest) setting, the Pareto front is the set no
other setting beats in both time and error; one real setting runs end to end (slow)."""

import json

import numpy as np
import pytest

from microslip import case as cases
from microslip.bench import trade
from microslip.cli import main


def test_every_setting_is_a_valid_case_with_its_knobs_set():
    base = cases.load("cases/15_blisk_damper.toml").data
    for s in trade.SETTINGS:
        data = trade.case_data(base, s, 3120.0, 3180.0)
        cases.check(data, "trade")  # raises on any fault
        p = data["geometry"]["parameters"]
        assert (p["contact_n_axial"], p["contact_n_flank"]) == s.grid
        assert data["harmonics"]["max"] == s.harmonics
        assert data["reduction"]["modes"] == s.modes
        sizes = {"size": 0.008, "blade_size": 0.004, **base["geometry"]["parameters"]}
        for name in ("size", "blade_size"):  # (the model's defaults where the case has none)
            assert p[name] == pytest.approx(s.mesh * sizes[name])
        assert [a["type"] for a in data["analysis"]] == ["frf"]
    assert base["analysis"][0]["name"] == "frf"  # the base case itself is left alone
    # the reference is the finest in every knob
    first = trade.SETTINGS[0]
    assert first.pairs == max(s.pairs for s in trade.SETTINGS)
    assert first.harmonics == max(s.harmonics for s in trade.SETTINGS)
    assert first.modes == "auto" and first.mesh == min(s.mesh for s in trade.SETTINGS)


def test_the_pareto_front_keeps_the_settings_no_other_beats_in_both():
    cost = np.array([10.0, 1.0, 5.0, 2.0, 3.0, 7.0])
    error = np.array([0.0, 4.0, 1.0, 4.0, 2.0, np.nan])
    # 3 is beaten by 1 (cheaper, as good); 5 has no error measured
    assert trade.pareto_front(cost, error).tolist() == [1, 4, 2, 0]
    # against a brute force over random sets
    rng = np.random.default_rng(3)
    for _ in range(20):
        c, e = rng.random(12), rng.random(12)
        front = set(trade.pareto_front(c, e).tolist())
        beaten = {i for i in range(12) for j in range(12)
                  if j != i and c[j] <= c[i] and e[j] <= e[i] and (c[j] < c[i] or e[j] < e[i])}
        assert front == set(range(12)) - beaten


def test_the_changes_are_against_the_reference_row():
    curve = [[3100.0, 3150.0, 3200.0], [1.0e-3, 2.0e-3, 1.0e-3]]
    rows = [{"omega": 3150.0, "amplitude": 2.0e-3, "curve": curve, "stuck": [3152.0, 2.5e-3]},
            {"omega": 3151.5, "amplitude": 2.1e-3, "curve": curve, "stuck": [3153.0, 3.0e-3]}]
    ch = trade.changes(rows, rows[0])
    assert ch[0] == {"d_omega": 0.0, "d_amplitude_pct": 0.0, "frf_error_pct": 0.0,
                     "d_stuck_omega": 0.0, "d_ratio_pct": 0.0}
    assert ch[1]["d_stuck_omega"] == pytest.approx(1.0)
    assert ch[1]["d_ratio_pct"] == pytest.approx(100 * (0.7 / 0.8 - 1))  # 2.1/3 vs 2/2.5
    assert ch[1]["d_omega"] == pytest.approx(1.5)
    assert ch[1]["d_amplitude_pct"] == pytest.approx(5.0)


def test_the_frf_error_counts_a_shift_as_well_as_a_scale():
    w = np.linspace(3100.0, 3200.0, 401)

    def peak(w0, a=1.0):  # a resonance of half-power width ~2 rad/s
        return a / np.sqrt(1.0 + ((w - w0) / 1.0) ** 2)

    ref = [w, peak(3150.0)]
    assert trade.frf_error(ref, ref) == 0.0
    # 2 % higher everywhere: 2 % of the peak, where the peak is
    assert trade.frf_error([w, peak(3150.0, 1.02)], ref) == pytest.approx(2.0, rel=1e-9)
    # the same peak 10 widths away: nearly all of it missed (the peak against the tail)
    shifted = trade.frf_error([w + 0.0, peak(3160.0)], ref)
    assert shifted == pytest.approx(100 * (1 - 1 / np.sqrt(1 + 10.0**2)), rel=1e-3)
    # compared where both are computed: a curve on other frequencies is interpolated; the
    # bound is the reference's own linear interpolation at the top (spacing 0.25, width 1:
    # h^2 |y''| / 8 = 1.6 % at most)
    w2 = np.linspace(3120.0, 3180.0, 1201)
    assert trade.frf_error([w2, 1.0 / np.sqrt(1 + (w2 - 3150.0) ** 2)], ref) < 1.6


@pytest.mark.parametrize("args, expected", [
    (["--only", "finest,nonsense"], "unknown setting(s) nonsense"),
    (["--start", "3200", "--stop", "3100"], "expected 0 < start < stop"),
    (["--case", "nowhere.toml"], "cannot read the file"),
])
def test_bad_input_is_one_line_and_exit_2(capsys, args, expected):
    assert main(["bench", "trade", *args]) == 2
    err = capsys.readouterr().err
    assert expected in err and "Traceback" not in err


@pytest.mark.slow
def test_the_cheapest_setting_runs_end_to_end(tmp_path, capsys):
    assert main(["bench", "trade", "--only", "quick,cheapest", "--out", str(tmp_path)]) == 0
    rows = json.loads((tmp_path / "trade.json").read_text())
    assert [r["setting"]["name"] for r in rows] == ["quick", "cheapest"]
    quick, cheapest = rows
    # a peak inside the window, above the fully stuck one's frequency less its width and
    # below that peak's amplitude (friction only takes energy out)
    assert 3120.0 < quick["omega"] < 3180.0 and quick["stuck"][0] - 5.0 < quick["omega"]
    assert 0.0 < quick["amplitude"] < quick["stuck"][1]
    assert quick["d_amplitude_pct"] == 0.0 and quick["frf_error_pct"] == 0.0
    assert cheapest["total_s"] > 0
    assert (tmp_path / "trade.png").stat().st_size > 10_000
    assert "Pareto front" in capsys.readouterr().out


def test_a_setting_that_fails_in_its_process_is_one_error_here():
    """The fresh process's fault comes back as a RuntimeError naming it (not a hang, not a
    child left running)."""
    with pytest.raises(RuntimeError, match="Error"):
        trade.cold({"geometry": {"model": "nonsense"}}, "trade")
