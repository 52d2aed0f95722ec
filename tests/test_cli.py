"""The `microslip` command: outputs and error messages."""

import pytest

from microslip.cli import main


def test_demo_prints_the_peak(capsys):
    assert main(["demo", "--harmonics", "3", "--samples", "64"]) == 0
    out = capsys.readouterr().out
    assert "peak max|x| = 1.8" in out and "(complete)" in out


def test_mesh_writes_files(tmp_path):
    case = tmp_path / "beam.toml"
    case.write_text('[geometry]\nmodel = "beam"\n[geometry.parameters]\nsize = 0.02\n')
    assert main(["mesh", str(case), "--out", str(tmp_path / "o"), "--no-pictures"]) == 0
    assert (tmp_path / "o" / "mesh.msh").stat().st_size > 0
    assert (tmp_path / "o" / "mesh.vtu").stat().st_size > 0


@pytest.mark.parametrize(
    "text,msg",
    [
        ('[geometry]\nmodel = "teapot"\n', "geometry.model = 'teapot'"),
        ('[geometry]\nmodel = "beam"\ncolour = 1\n', "geometry.colour: unknown key"),
        ('title = "x"\n[geometry]\nmodel = "beam"\n[[analysis]]\ntype = "fly"\n',
         "[model]: missing"),
        ('[geometry]\nmodel = "beam"\n[geometry.parameters]\nsize = -1.0\n', "size"),
        ('[geometry\n', "not valid TOML"),
    ],
)
def test_mesh_rejects_bad_cases(tmp_path, capsys, text, msg):
    case = tmp_path / "bad.toml"
    case.write_text(text)
    assert main(["mesh", str(case), "--out", str(tmp_path / "o"), "--no-pictures"]) == 2
    assert msg in capsys.readouterr().err


def test_unknown_command_is_a_usage_error(capsys):
    assert main(["fly"]) == 2
    assert capsys.readouterr().err == (
        "microslip: 'fly' is not a command; the commands: demo, run, check, show, render, "
        "report, compare, mesh, cache, bench (microslip --help: what each does)\n")
    assert main([]) == 2
    assert "usage: microslip" in capsys.readouterr().err


def test_version(capsys):
    from importlib.metadata import version

    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"microslip {version('microslip')}\n"


def test_top_level_help_lists_version(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: microslip [--version] {demo,run,check,show,render,report,"
                          "compare,mesh,cache,bench}")


@pytest.mark.parametrize("command", [["run"], ["check"], ["show"], ["mesh"], ["demo"], ["compare"],
                                     ["report"],
                                     ["bench", "core"], ["bench", "mesh"],
                                     ["bench", "reduction"], ["bench", "teaching"],
                                     ["bench", "assembly"], ["bench", "trade"]])
def test_help_names_the_real_program(capsys, command):
    with pytest.raises(SystemExit) as exit_:
        main([*command, "--help"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: microslip {' '.join(command)} ")


def test_bench_reduction_prints_each_row_once(capsys):
    """The coarse blisk sector, one ND: each table row once on stdout (progress goes to
    stderr), and a single run is not called a median."""
    from microslip.bench import reduction_cost

    mesh = reduction_cost.blisk_mesh(4.0)
    reduction_cost.bench_reduction(mesh, [0], 5, ["superlu"], order=1, bodies=("blisk",))
    out = capsys.readouterr().out
    assert "single run" in out and "median of" not in out
    rows = [line for line in out.splitlines() if line.split()[:3] == ["superlu", "blisk", "0"]]
    assert len(rows) == 1, out
    assert reduction_cost._runs(3) == "median of 3 runs"


def test_run_dry_run_lists_the_stages_and_computes_nothing(tmp_path, capsys):
    from microslip.cli import main

    assert main(["run", "cases/01_sdof_wall.toml", "--dry-run", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "dry run: nothing computed" in out and "stages run" in out
    assert "frf_force: curve 1" in out
    assert not (tmp_path / "results.h5").exists()


def test_a_demo_too_large_is_refused_before_any_work(capsys):
    """--harmonics 1000 --samples 16384 ran over ten minutes at 1.4 GB with no word; it is
    estimated and refused at once, as a case's check refuses what it cannot run."""
    import time

    t = time.perf_counter()
    assert main(["demo", "--harmonics", "1000", "--samples", "16384"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(
        "microslip demo: --harmonics 1000 --samples 16384: ~") and "min estimated" in err
    assert time.perf_counter() - t < 10.0  # no sweep started
