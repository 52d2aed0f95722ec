"""Flat-punch contact stiffness against hand-computed values; frames; bad input."""

import math

import numpy as np
import pytest

from microslip.fe import contact_stiffness as cs
from microslip.fe.fem import Material
from microslip.geometry import ContactPatch

STEEL = Material(2.0e11, 0.3, 7850.0)
TITANIUM = Material(1.1e11, 0.34, 4430.0)


def _patch(area=1.0e-4, n1=3, n2=4, normal=(0.0, 0.0, 1.0)):
    nodes_a = np.arange(n1 * n2).reshape(n1, n2)
    return ContactPatch("p", "damper", "blisk", nodes_a, nodes_a + n1 * n2,
                        np.asarray(normal), area)


def test_flat_punch_steel_on_steel_by_hand():
    # A = 1e-4 m^2: a = sqrt(1e-4 / pi) = 5.641895835e-3 m
    # E* = 1 / (2 * 0.91 / 2e11) = 1.098901099e11 Pa -> kn = 2 a E* = 1.239977e9 N/m
    # G = 2e11 / 2.6 = 7.692307692e10 Pa, G* = 1 / (2 * 1.7 / G) = 2.262443439e10 Pa
    # -> kt = 8 a G* = 1.021158e9 N/m
    kn, kt = cs.flat_punch_stiffness(1.0e-4, STEEL, STEEL)
    assert kn == pytest.approx(1.239977e9, rel=1e-6)
    assert kt == pytest.approx(1.021158e9, rel=1e-6)


def test_flat_punch_dissimilar_by_hand():
    # Steel on titanium, A = 4e-6 m^2: a = 1.128379167e-3 m
    # 1/E* = 0.91/2e11 + (1 - 0.34^2)/1.1e11 = 4.55e-12 + 8.04e-12 -> E* = 7.9428118e10
    # G_ti = 1.1e11 / 2.68 = 4.104477612e10; 1/G* = 1.7/7.692307692e10 + 1.66/4.104477612e10
    #      = 2.21e-11 + 4.0443636e-11 -> G* = 1.5988837e10
    kn, kt = cs.flat_punch_stiffness(4.0e-6, STEEL, TITANIUM)
    a = 1.128379167e-3
    assert kn == pytest.approx(2 * a / (0.91 / 2e11 + (1 - 0.34**2) / 1.1e11), rel=1e-9)
    assert kn == pytest.approx(2 * a * 7.9428118e10, rel=1e-6)
    assert kt == pytest.approx(8 * a * 1.5988837e10, rel=1e-6)


def test_spread_conserves_total_and_override():
    patch = _patch()
    ks = cs.patch_stiffness(patch, STEEL, TITANIUM)
    kn, kt = cs.flat_punch_stiffness(patch.area, STEEL, TITANIUM)
    assert ks.normal.shape == (3, 4)
    assert ks.total_normal == pytest.approx(kn, rel=1e-14)
    assert ks.total_tangential == pytest.approx(kt, rel=1e-14)
    assert np.ptp(ks.normal) == 0.0  # evenly spread
    # Per-area override [N/m^3]: total = k_area * A.
    ks = cs.patch_stiffness(patch, STEEL, STEEL, per_area=(1e13, 4e12))
    assert ks.total_normal == pytest.approx(1e13 * 1e-4, rel=1e-14)
    assert ks.tangential[0, 0] == pytest.approx(4e12 * 1e-4 / 12, rel=1e-14)


def test_frames_orthonormal_right_handed():
    normal = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    patch = _patch(normal=normal)
    # Grid: first direction along +z, second in the contact plane.
    i, j = np.meshgrid(np.arange(3), np.arange(4), indexing="ij")
    t_plane = np.array([-1.0, 1.0, 0.0]) / math.sqrt(2)
    pts = np.zeros((24, 3))
    pts[:12] = (i.ravel()[:, None] * [0, 0, 1e-3]) + j.ravel()[:, None] * t_plane * 1e-3
    frames = cs.contact_frames(patch, pts)
    assert frames.shape == (3, 4, 3, 3)
    F = frames[1, 2]
    np.testing.assert_allclose(F @ F.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(F) == pytest.approx(1.0)
    np.testing.assert_allclose(F[2], normal)
    np.testing.assert_allclose(F[0], [0, 0, 1], atol=1e-15)  # t1 along the grid's first axis
    # Normal relative displacement is positive on approach: body a moving along +n.
    assert (F @ (1e-6 * normal - 0.0))[2] > 0


@pytest.mark.parametrize("area", [0.0, -1.0, float("nan")])
def test_bad_area(area):
    with pytest.raises(ValueError, match="area"):
        cs.flat_punch_stiffness(area, STEEL, STEEL)


def test_bad_per_area():
    with pytest.raises(ValueError, match="per_area"):
        cs.patch_stiffness(_patch(), STEEL, STEEL, per_area=(1e13, -1.0))
