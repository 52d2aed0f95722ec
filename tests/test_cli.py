"""The `microslip` command: outputs and error messages."""

from pathlib import Path

import pytest

from pipeline.cli import main


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
        ('[geometry]\nmodel = "teapot"\n', "model = 'teapot'"),
        ('[geometry]\nmodel = "beam"\ncolour = 1\n', "unknown keys ['colour']"),
        ('[solver]\nH = 3\n', "no [geometry] table"),
        ('[geometry]\nmodel = "beam"\n[geometry.parameters]\nsize = -1.0\n', "size"),
        ('[geometry\n', "cannot read"),
    ],
)
def test_mesh_rejects_bad_cases(tmp_path, capsys, text, msg):
    case = tmp_path / "bad.toml"
    case.write_text(text)
    assert main(["mesh", str(case), "--out", str(tmp_path / "o"), "--no-pictures"]) == 2
    assert msg in capsys.readouterr().err


def test_shipped_cases_parse():
    import tomllib

    for path in sorted(Path(__file__).parents[1].glob("cases/*.toml")):
        with open(path, "rb") as f:
            assert "geometry" in tomllib.load(f) or path.stem.startswith("teach")


def test_unknown_command_is_a_usage_error(capsys):
    assert main(["fly"]) == 2
    assert "usage: microslip" in capsys.readouterr().err
