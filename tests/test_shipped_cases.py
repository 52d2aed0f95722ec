"""The shipped cases teach in order: numbered as the reference text reads (the single DOF
first, the full-scale studies last), each title naming what of the text it reproduces,
every one valid, and the lumped ones running to the end without a warning."""

import re
import tomllib
from pathlib import Path

import h5py
import pytest

from microslip.cli import main

CASES = Path(__file__).parents[1] / "cases"
SHIPPED = sorted(CASES.glob("*.toml"))


def _table(path: Path) -> dict:
    with open(path, "rb") as f:
        return tomllib.load(f)


LUMPED = [p for p in SHIPPED if "model" in _table(p)]


def test_the_cases_are_numbered_in_learning_order():
    numbers = [int(re.fullmatch(r"(\d\d)_[a-z_]+\.toml", p.name)[1]) for p in SHIPPED]
    assert numbers == list(range(1, len(SHIPPED) + 1))
    assert SHIPPED[0].name == "01_sdof_wall.toml"  # the main job, the text's first model
    # every lumped model before the first meshed one, the studies last
    assert SHIPPED[: len(LUMPED)] == LUMPED
    assert SHIPPED[-1].name == "17_mistuned_blisk.toml"
    for p in SHIPPED:
        title = _table(p)["title"]
        assert re.search(r"Firrone & Zucca (Fig\.|section)|benchmark", title), p.name


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_case_passes_check(path, capsys):
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"{path}: ok" in out or "reduction ~" in out, out
    assert "warning:" not in out


@pytest.mark.slow
@pytest.mark.parametrize("path", LUMPED, ids=lambda p: p.stem)
def test_the_lumped_cases_run_to_the_end_without_a_warning(path, tmp_path, capsys):
    assert main(["run", str(path), "--out", str(tmp_path), "--workers", "0"]) == 0
    out = capsys.readouterr().out
    assert "warning:" not in out
    with h5py.File(tmp_path / "results.h5") as f:
        assert f.attrs["status"] == "complete"
        analyses = [a for a in _table(path)["analysis"]]
        assert all(f[a["name"]].attrs["status"] == "complete" for a in analyses)
    # its page: every analysis there with its pictures, nothing it could not show
    page = (tmp_path / "report.html").read_text()
    assert all(f"id='a-{a['name']}'" in page for a in analyses)
    assert "class='missing'" not in page and page.count("data:image/png") >= len(analyses)


def test_a_case_named_without_its_number_is_found_in_one_line(capsys):
    """Commands written before the cases were numbered (``cases/sdof_wall.toml``) name the
    file the case is now."""
    assert main(["check", str(CASES / "sdof_wall.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"cannot read the file: No such file or directory; the shipped cases are " \
           f"numbered now: {CASES / '01_sdof_wall.toml'}" in err


def test_a_case_under_an_earlier_number_is_found_in_one_line(capsys):
    """The meshed cases moved one number up when the nonlinear-modes case joined the
    lumped ones: ``cases/10_blisk_quick.toml`` names the file it is now."""
    assert main(["check", str(CASES / "10_blisk_quick.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"numbered now: {CASES / '11_blisk_quick.toml'}" in err
