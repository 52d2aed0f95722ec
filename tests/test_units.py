"""An imported deck read in the wrong units is said, not solved in silence: the unit assumed
when the case gives none, and a warning naming the units that make the numbers plausible."""

from pathlib import Path

import pytest

from microslip.case.units import BodyNumbers, faults, read_in, unit_lines
from microslip.cli import main
from microslip.geometry.imported import UNITS

CASES = Path(__file__).parents[1] / "cases"

#: Engineering materials of blades, disks and dampers (E [Pa], density [kg/m^3]): none is
#: implausible in SI.
MATERIALS = {"steel": (2.1e11, 7850.0), "titanium": (1.1e11, 4430.0),
             "nickel alloy": (2.0e11, 8190.0), "aluminium": (7.0e10, 2700.0),
             "CFRP (fibre direction)": (1.4e11, 1600.0), "tungsten carbide": (6.5e11, 15600.0),
             "PEEK": (3.6e9, 1300.0)}


@pytest.mark.parametrize("name", MATERIALS)
def test_engineering_materials_in_si_are_plausible(name):
    E, rho = MATERIALS[name]
    assert faults(BodyNumbers("b", 0.04, E, rho)) == []


@pytest.mark.parametrize("units", ["mm-t-s", "mm-kg-s", "in-lbf-s"])
def test_a_steel_blade_in_other_units_read_as_si_is_flagged(units):
    """A 40 mm steel blade written in ``units`` (its numbers converted from SI by that
    system) and read as SI: something is implausible, and reading it in ``units`` fits."""
    u = UNITS[units]
    as_written = BodyNumbers("blade", 0.04 / u.length, 2.1e11 / u.stress, 7850.0 / u.density,
                             from_file=True)
    assert faults(as_written)
    assert faults(read_in(as_written, UNITS["SI"], u)) == []


def test_a_case_material_does_not_scale_with_the_file_s_units():
    b = BodyNumbers("blade", 40.0, 2.1e11, 7850.0, from_file=False)
    moved = read_in(b, UNITS["SI"], UNITS["mm-t-s"])
    assert moved.size == pytest.approx(0.04) and moved.modulus == 2.1e11
    notes, warnings = unit_lines([b], "SI", False, "blade.inp")
    assert notes and "read in SI" in notes[0]
    assert warnings == ['body blade read in SI is implausible: 40 m across (a blade, disk or '
                        'damper: 0.0005..10 m); every body is plausible in units = "mm-t-s"']


def _deck_case(tmp_path: Path, units: str | None) -> Path:
    text = (CASES / "13_imported_blade.toml").read_text()
    text = text.replace('units = "mm-t-s"', f'units = "{units}"' if units else "")
    text = text.replace('file = "imported_blade.inp"',
                        f'file = "{(CASES / "imported_blade.inp").as_posix()}"')
    case = tmp_path / "deck.toml"
    case.write_text(text)
    return case


def test_check_says_the_unit_assumed_and_the_units_that_fit(tmp_path, capsys):
    """The shipped millimetre deck with units left out: check says SI was assumed and that
    the blade (130 m, E = 2.1e5 Pa read so) fits mm-t-s; with its units, neither line."""
    assert main(["check", str(_deck_case(tmp_path, None))]) == 0
    out = capsys.readouterr().out
    assert "note: geometry.units not given: imported_blade.inp is read in SI" in out
    assert ("warning: body BLADE read in SI is implausible: 130 m across" in out
            and 'every body is plausible in units = "mm-t-s"' in out)
    assert main(["check", str(_deck_case(tmp_path, "mm-t-s"))]) == 0
    out = capsys.readouterr().out
    assert "note:" not in out and "warning:" not in out


def test_mesh_says_it_too(tmp_path, capsys):
    case = _deck_case(tmp_path, None)
    assert main(["mesh", str(case), "--out", str(tmp_path / "o"), "--no-pictures"]) == 0
    out = capsys.readouterr().out
    assert "[geometry] note: geometry.units not given" in out
    assert "warning: [geometry] body BLADE read in SI is implausible" in out
