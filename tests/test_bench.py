"""Every `microslip bench` command runs on its smallest setting and prints its figures
(mesh, reduction and trade have their own tests beside their subjects)."""

import pytest

from microslip.cli import main


@pytest.mark.slow  # ~11 s of kernel timings at three sizes: the fast suite's 5 min
def test_bench_core_prints_time_per_point_and_contact_cost(capsys):
    assert main(["bench", "core", "--repeat", "1", "--skip-accuracy"]) == 0
    out = capsys.readouterr().out
    assert "status complete" in out and "per point" in out
    rows = [line.split() for line in out.splitlines() if "stick-slip" in line]
    assert [r[0] for r in rows] == ["100", "1000", "10000"]
    assert all(float(r[1]) > 0 for r in rows)  # time ms


@pytest.mark.slow  # a benchmark's smoke run (the cases themselves: test_shipped_cases)
def test_bench_teaching_finds_and_runs_the_shipped_cases(capsys):
    assert main(["bench", "teaching", "--skip-frf", "--cases", "hysteresis_loops"]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if "02_hysteresis_loops.toml" in line)
    assert row.split()[-1] == "complete", out


def test_bench_teaching_refuses_an_unknown_case_in_one_line(capsys):
    assert main(["bench", "teaching", "--skip-frf", "--cases", "sdof_wall,nowhere"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--cases sdof_wall,nowhere: no case nowhere" in err


@pytest.mark.slow
def test_bench_teaching_frf_table_matches_hbm_and_dti(capsys):
    assert main(["bench", "teaching", "--repeat", "1", "--dti-points", "2", "--skip-set"]) == 0
    out = capsys.readouterr().out
    # the DTI's error falls with the steps per period at the observed order ~2 (trapezoidal)
    assert "Richardson (order 2." in out or "Richardson (order 1.9" in out, out
    assert "HBM faster" in out


@pytest.mark.slow
def test_bench_assembly_smallest_grid(tmp_path, capsys):
    args = ["--grids", "6x4", "--harmonics", "1", "--points", "2", "--cache", str(tmp_path)]
    assert main(["bench", "assembly", *args]) == 0
    rows = [line.split() for line in capsys.readouterr().out.splitlines()
            if line.split()[:2] == ["2x24", "1"]]
    assert len(rows) == 1 and rows[0][2] == "864"


def test_bench_elements_converges_for_every_shape(monkeypatch, capsys):
    """On two coarse grids and a reference one grid finer, every shape's error falls with
    the grid and the quadratic elements beat the linear ones on the same grid."""
    from microslip.bench import element_orders

    monkeypatch.setattr(element_orders, "GRIDS", ((5, 1, 1), (10, 1, 1)))
    monkeypatch.setattr(element_orders, "REFERENCE_GRID", (20, 2, 2))
    assert element_orders.main(["--repeats", "1"]) == 0
    rows = [line.split() for line in capsys.readouterr().out.splitlines()[2:]]
    error = {(r[0], r[1], r[2] + r[3] + r[4]): abs(float(r[7].rstrip("%"))) for r in rows}
    for shape in ("hexahedron", "wedge", "tetra"):
        for order in ("1", "2"):
            assert error[shape, order, "(10,1,1)"] < error[shape, order, "(5,1,1)"]
        assert error[shape, "2", "(5,1,1)"] < error[shape, "1", "(5,1,1)"]


@pytest.mark.slow  # a benchmark's smoke run (both solvers agree: test_jacobian)
def test_bench_solvers_finds_the_same_solutions_both_ways(capsys):
    """The Duffing case by dense LUs and by the structured Jacobian: the same points (to
    1e-8 of each dataset's largest entry), verdicts and bifurcations; the exit says so."""
    from pathlib import Path

    case = Path(__file__).resolve().parents[1] / "cases" / "05_duffing.toml"
    assert main(["bench", "solvers", str(case)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("05_duffing: dense ")
    rows = {line.split()[0]: line for line in out.splitlines()[1:]}
    assert {"solutions", "verdicts", "bifurcations"} <= set(rows), out
    size = float(rows["solutions"].split("largest difference ")[1].split()[0])
    assert size <= 1e-8, out


def test_bench_solvers_without_cases_says_where_it_looked(tmp_path, monkeypatch, capsys):
    """From an installed wheel there is no cases/ folder: one line and exit 2, not a silent
    success over no case."""
    from microslip.bench import solvers

    monkeypatch.setattr(solvers, "CASES", tmp_path)
    assert main(["bench", "solvers"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(tmp_path) in err[0] and "source checkout" in err[0]
