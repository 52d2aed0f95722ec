"""The modes analysis: a body's lowest modes unreduced (held as its reduction holds it, per
nodal diameter) against a dense eigen-solve of the same matrices and its reduced model's
(Rayleigh-Ritz upper bounds, converging as modes are added); end to end on the imported
blade: results.h5, the picture, one line per body."""

import h5py
import matplotlib.image as mpimg
import numpy as np
import pytest
import scipy.linalg as sla
from test_supports import _pie

from microslip.cli import main
from microslip.fe import bodies, cyclic, fem
from microslip.fe.body_modes import body_modes, frequencies_hz
from microslip.geometry.structured import block

STEEL = fem.Material(2.0e11, 0.3, 7850.0)


@pytest.mark.parametrize("h", [0, 1, 2])
def test_unreduced_modes_are_the_dense_eigenpairs_and_bound_the_reduced_ones(h):
    mesh = _pie(6, 1)
    mesh = type(mesh)(mesh.model, mesh.points, mesh.tetrahedra, mesh.bodies,
                      node_sets={**mesh.node_sets, "disk/response": np.array([1])},
                      cyclic=mesh.cyclic, hexahedra=mesh.hexahedra, wedges=mesh.wedges)
    errors = []
    for count in (6, 24):
        spec = bodies.BodySpec("disk", STEEL, master_sets=("disk/response",),
                                  clamped_sets=("disk/rim",), n_modes=count)
        (model,) = bodies.reduce_body(mesh, spec, (h,)).values()
        found = body_modes(mesh, spec, model, 5, h)
        body = fem.assemble(mesh, "disk", STEEL)
        sector = cyclic.sector_model(body, mesh.node_sets["disk/rim"], mesh.cyclic["disk"], h)
        lam, phi = sla.eigh(sector.stiffness.toarray(), sector.mass.toarray())
        # the shift-invert Lanczos solve against LAPACK's dense one: its 1e-12 residual
        np.testing.assert_allclose(found.frequencies_hz, frequencies_hz(lam[:5]), rtol=1e-9)
        # the first shape is the dense eigenvector's (its vertices), up to a phase
        dense = (sector.expansion @ phi[:, 0])[body.node_dofs].ravel()
        shape = found.shapes[0].ravel()
        cosine = abs(np.vdot(dense, shape)) / (np.linalg.norm(dense) * np.linalg.norm(shape))
        assert cosine > 1 - 1e-9
        # Rayleigh-Ritz: the reduced model's frequencies lie above (to round-off)
        assert np.all(found.relative_error > -1e-9)
        errors.append(np.abs(found.relative_error).max())
    assert errors[1] < errors[0]  # more fixed-interface modes, a smaller error


def test_a_free_body_keeps_its_rigid_modes_apart():
    """Neither clamped nor supported: six rigid modes at 0 Hz, then the elastic ones, as a
    dense solve has them."""
    mesh = block("hexahedron", (0.2, 0.02, 0.02), (6, 2, 2))
    spec = bodies.BodySpec("block", STEEL, master_sets=("block/tip",), n_modes=20)
    (model,) = bodies.reduce_body(mesh, spec).values()
    found = body_modes(mesh, spec, model, 9)
    body = fem.assemble(mesh, "block", STEEL)
    dense = frequencies_hz(sla.eigh(body.stiffness.toarray(), body.mass.toarray(),
                                    eigvals_only=True)[:9])
    assert np.all(found.frequencies_hz[:6] < 1e-3 * found.frequencies_hz[6])
    np.testing.assert_allclose(found.frequencies_hz[6:], dense[6:], rtol=1e-9)


CASE = """
title = "modes of the imported blade"
[geometry]
model = "import"
file = "{deck}"
units = "mm-t-s"
[reduction]
material = "file"
modes = "auto"
[reduction.bodies.BLADE]
masters = ["TIP"]
clamped = ["FLANK_L", "FLANK_R"]
[[analysis]]
name = "clamped"
type = "modes"
count = 8
"""


# end to end on a deck (the modes analysis: the blisk test here; the deck: test_imported_blade)
@pytest.mark.slow
def test_modes_of_an_imported_blade_end_to_end(tmp_path, capsys):
    from pathlib import Path

    deck = Path(__file__).parent.parent / "cases" / "imported_blade.inp"
    case = tmp_path / "modes.toml"
    case.write_text(CASE.format(deck=deck))
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 0
    said = capsys.readouterr().out
    assert "[clamped] BLADE (" in said and "reduced model's error at most" in said
    with h5py.File(tmp_path / "out" / "results.h5") as f:
        g = f["clamped/BLADE/body"]
        f_hz, reduced = g["frequencies_hz"][()], g["reduced_hz"][()]
        assert g["shapes"].shape == (8, len(g["nodes"]), 3)
    # "auto" keeps the modes below 4 x the 10th fixed-interface frequency: the first eight
    # within 0.1 % (the README's statement), the first above
    assert np.all(reduced >= f_hz * (1 - 1e-12)) and np.all(reduced / f_hz - 1 < 1e-3)
    # show summarises it per body (no curves to count)
    assert main(["show", str(tmp_path / "out")]) == 0
    assert "  BLADE body: f [Hz] " in capsys.readouterr().out
    # render draws the same picture from results.h5 alone, pixel for pixel
    assert main(["render", str(tmp_path / "out"), "--out", str(tmp_path / "again")]) == 0
    np.testing.assert_array_equal(mpimg.imread(tmp_path / "again" / "clamped.png"),
                                  mpimg.imread(tmp_path / "out" / "clamped.png"))
