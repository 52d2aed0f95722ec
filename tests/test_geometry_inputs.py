"""Bad input is refused before Gmsh runs, with the parameter, value and allowed range."""

import gmsh
import pytest

from microslip import geometry
from microslip.geometry import GeometryBuildError, GeometryParameterError
from microslip.geometry.blisk import BliskParameters, blisk_sector
from microslip.geometry.params import describe
from microslip.geometry.root_joint import RootJointParameters, root_joint


@pytest.fixture
def no_gmsh(monkeypatch):
    """Fail loudly if a model builder reaches Gmsh."""

    def forbidden(*args, **kwargs):
        raise AssertionError("Gmsh was called before validation finished")

    monkeypatch.setattr(gmsh, "initialize", forbidden)


BLISK_BAD = [
    # (overrides, parameter named in the message, fragment of the allowed range)
    ({"sectors": 2}, "sectors", "[3, 400]"),
    ({"sectors": 12.5}, "sectors", "integer"),
    ({"size": 0.0}, "size", "(0, 10]"),
    ({"size": -0.01}, "size", "(0, 10]"),
    ({"blade_size": 0.0}, "blade_size", "(0, 10]"),
    ({"contact_n_axial": 1}, "contact_n_axial", "[2, 500]"),
    ({"contact_n_flank": 1}, "contact_n_flank", "[2, 500]"),
    ({"alpha_left": 0.0}, "alpha_left", "(0, 90)"),
    ({"alpha_right": 90.0}, "alpha_right", "(0, 90)"),
    ({"alpha_left": float("nan")}, "alpha_left", "(0, 90)"),
    ({"blade_chord": 0.06}, "blade_chord", "blade wider than the pitch"),
    ({"blade_stagger": 0.0, "blade_chord": 0.04}, "blade_chord", "width = 0.03"),
    ({"damper_top_width": 0.001}, "damper_top_width", "> platform_gap"),
    ({"damper_height": 0.0055}, "damper_height", "does not fit the pocket"),
    ({"damper_length": 0.031}, "damper_length", "<= width"),
    ({"pocket_flank_height": 0.012}, "pocket_flank_height", "80 % of the pitch"),
    ({"r_platform": 0.09}, "r_platform", "> r_bore"),
    ({"pocket_depth": 0.08}, "pocket_depth", "80 %"),
    ({"platform_gap": 0.02}, "platform_gap", "half the pitch"),
    ({"size": 1e-5}, "size", "tets estimated"),
]


@pytest.mark.parametrize(("overrides", "name", "allowed"), BLISK_BAD)
def test_blisk_rejects_bad_input_before_gmsh(no_gmsh, overrides, name, allowed):
    with pytest.raises(GeometryParameterError) as err:
        blisk_sector(**overrides)
    msg = str(err.value)
    assert name in msg and allowed in msg, msg


ROOT_BAD = [
    ({"sectors": 1}, "sectors", "[3, 400]"),
    ({"flank_angle": 95.0}, "flank_angle", "(0, 90)"),
    ({"clearance": 0.004}, "clearance", "< flank_height / 3"),
    ({"flank_height": 0.08}, "flank_height", "80 %"),
    ({"neck_width": 0.05}, "flank_height", "pitch"),
    ({"blade_chord": 0.2}, "blade_chord", "blade wider than the pitch"),
    ({"r_rim": 0.04}, "r_rim", "> r_bore"),
    ({"contact_n_flank": 0}, "contact_n_flank", "[2, 500]"),
    ({"width": 0.0}, "width", "(0, 10]"),
]


@pytest.mark.parametrize(("overrides", "name", "allowed"), ROOT_BAD)
def test_root_joint_rejects_bad_input_before_gmsh(no_gmsh, overrides, name, allowed):
    with pytest.raises(GeometryParameterError) as err:
        root_joint(**overrides)
    msg = str(err.value)
    assert name in msg and allowed in msg, msg


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: geometry.beam(size=0.0), "size"),
        (lambda: geometry.beam(length=-1.0), "length"),
        (lambda: geometry.annular_sector(sectors=2), "sectors"),
        (lambda: geometry.annular_sector(r_inner=0.2, r_outer=0.1), "r_outer"),
        (lambda: geometry.annular_sector(size=-1.0), "size"),
    ],
)
def test_simple_models_reject_bad_input_before_gmsh(no_gmsh, call, name):
    with pytest.raises(GeometryParameterError, match=name):
        call()


def test_error_is_a_value_error_with_value_in_message(no_gmsh):
    with pytest.raises(ValueError, match=r"sectors = 2: must be an integer in \[3, 400\]"):
        blisk_sector(sectors=2)


def test_gmsh_failure_names_the_parameters_and_closes_the_session(monkeypatch):
    def broken(dim=3):
        raise Exception("simulated mesher failure")

    monkeypatch.setattr(gmsh.model.mesh, "generate", broken)
    with pytest.raises(GeometryBuildError) as err:
        root_joint(flank_angle=50.0)
    msg = str(err.value)
    assert "simulated mesher failure" in msg and '"flank_angle": 50.0' in msg
    assert not gmsh.isInitialized()


@pytest.mark.parametrize("cls", [BliskParameters, RootJointParameters])
def test_every_parameter_has_unit_default_range_and_meaning(cls):
    rows = describe(cls)
    assert len(rows) >= 15
    for name, unit, default, bound, doc in rows:
        assert unit and bound and doc, name
        assert default is not None, name
    cls().validate()  # the defaults are valid
