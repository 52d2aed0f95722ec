"""Contacts between named surfaces meshed independently (geometry.pairing, assembly.join):
the patch test of two blocks pressed together and of one slipping on the other, through the
whole chain (Craig-Bampton bodies, the assembly, the harmonic balance with the friction
law), the contact Jacobian against finite differences on an interpolated pair, a block on
the ground, and what a case declares (bodies, the finer side, the neighbour's side, faults).

The blocks: 40 x 40 mm, 20 mm high each, steel with nu = 0: under a uniform pressure p on
the top, with the bottom clamped, the exact solution is uniaxial (sigma_zz = -p, no lateral
strain), a linear field every mesh reproduces; what the contact adds is the uniform jump
p / k_area of its normal compliance.
"""

import dataclasses

import numpy as np
import pytest
from blocks import two_blocks, upper_block
from derivatives import fd_residual_jacobian

from microslip.app import structure
from microslip.assembly.join import join
from microslip.assembly.spec import AssemblySpec, NodalLoad, Output, PatchFriction
from microslip.fourier import Harmonics
from microslip.geometry.averaging import averaged_surfaces
from microslip.geometry.boundaries import MeshValidationError, SurfaceContact
from microslip.geometry.pairing import declare_contact, paired_contact
from microslip.laws.states import GROSS_SLIP, SAMPLE_SLIP, STICK_SLIP
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point

E, RHO, L, H = 2.0e11, 7800.0, 0.04, 0.02
P = 1.0e6  # [Pa] the pressure on the top
K_AREA = 1.0e16  # [N/m^3] stiff contact: its compliance p / K_AREA is 5e-4 of the blocks'


def stack(lower, upper):
    """The two blocks (lower None: the upper one on the ground) and their "interface"."""
    if lower is None:
        mesh = upper_block(*upper)
        c = declare_contact(mesh, "interface", ("upper/bottom",), ground=True)
    else:
        mesh = two_blocks(lower, upper, (L, L, H), (L, L, H), (0.0, 0.0))
        c = declare_contact(mesh, "interface", ("upper/bottom", "lower/top"))
    return dataclasses.replace(mesh, contacts={"interface": c})


def reduced(mesh, stiffness=True):
    red = {"material": {"youngs_modulus": E, "poisson_ratio": 0.0, "density": RHO},
           "order": 1, "modes": 12, "damping": {"modal_ratios": 0.01}}
    if stiffness:
        red["contact_stiffness"] = {"interface": {"normal": K_AREA, "tangential": K_AREA}}
    return structure.reduce_structure(mesh, red, None, progress=lambda s: None)


def model(mesh, st, mu, loads, harmonics=1, samples=16):
    spec = AssemblySpec(contacts=(PatchFriction("interface", mu),), engine_order=1,
                        loads=loads, outputs=(Output("top_z", "upper/top", "z"),
                                              Output("top_x", "upper/top", "x")))
    return join(mesh, st.models, st.patch_stiffness, spec, Harmonics.up_to(harmonics, samples))


PRESS = (NodalLoad("upper/top", "z", -P * L * L, 0, spread="area"),)


def pressed(lower, upper, tol):
    """(pressure per pair / P, top displacement [m], the mesh) of the blocks under P; the
    tangential loads of the pairs within ``tol`` of the total load."""
    mesh = stack(lower, upper)
    return (*pressed_mesh(mesh, tol), mesh)


def pressed_mesh(mesh, tol):
    """(pressure per pair / P, top displacement [m]) of a mesh of the blocks under P, stiff
    contact, mu large; the tangential loads of the pairs within ``tol`` of the total."""
    cm = model(mesh, reduced(mesh), 1e3, PRESS)
    p = OperatingPoint(100.0)
    r = solve_point(cm.hb, p)
    assert r.converged, r.reason
    state = cm.patches(r.x, p)["interface"]
    areas = paired_contact(mesh, "interface").pairing.areas
    assert np.abs(state.static[:, :2]).max() < tol * P * L * L  # no tangential load
    return state.static[:, 2] / areas / P, cm.output_coefficients(r.x, p)[0, 0]


# Pressure error (max over the pairs) of the weighted (dual mortar) coupling by sub-cells per
# facet edge in its integrals (geometry.pairing.SUBCELLS), lower / upper meshes:
#                              1        2        4 (default)   8
#   hex 3x3 / hex 7x7        3.4e-3   8.6e-4   2.2e-4        5.4e-5
#   hex 3x3 / tet 7x7        9.6e-3   1.4e-3   1.6e-4        2.1e-5
#   tet 3x3 / wedge 4x4      1.1e-2   1.3e-3   1.7e-4        2.1e-5
# (grids whose facet edges fall on the sub-cells' edges pass to round-off). The coupling by
# each node's own projection (node to segment) gives 14-30 % on the same meshes, not falling
# with refinement: it passes the pressure with side a's nodal rule, not side b's.
@pytest.mark.parametrize("lower, upper, tol", [
    (("hexahedron", (3, 3, 2)), ("hexahedron", (3, 3, 2)), 1e-9),  # matching: node for node
    (("hexahedron", (3, 3, 2)), ("hexahedron", (7, 7, 2)), 1e-3),
    (("hexahedron", (3, 3, 2)), ("tetra", (7, 7, 2)), 1e-3),
    (("tetra", (3, 3, 2)), ("wedge", (4, 4, 2)), 1e-3),
])
def test_non_matching_blocks_pressed_together_carry_the_uniform_pressure(lower, upper, tol):
    """Stiff contact, mu large: every pair carries p times its area, and the top moves as
    the glued stack's (uniaxial, exact) plus the contact's uniform compliance."""
    pressure, top, mesh = pressed(lower, upper, tol)
    assert paired_contact(mesh, "interface").pairing.matching == (lower == upper)
    np.testing.assert_allclose(pressure, 1.0, rtol=0, atol=tol)
    exact = -P * 2 * H / E - P / K_AREA
    # the top's error follows the pressure's, smeared over the block: tol / 10 holds
    assert top == pytest.approx(exact, rel=max(tol / 10, 1e-9))


def test_the_upper_block_slips_rigidly_beyond_mu_n():
    """A tangential traction beyond mu p on the pressed upper block (flat-punch stiffness),
    spread over its contact face (so that it does not tip the block): every pair slips with
    |T| = mu N, and the block moves as a rigid mass under Coulomb friction, whose first
    harmonic (H = 1) is m w^2 X = sqrt(F^2 - (4 mu N / pi)^2)."""
    mesh = stack(("hexahedron", (3, 3, 2)), ("tetra", (4, 4, 2)))
    st = reduced(mesh, stiffness=False)
    mu, F, w = 0.3, 1000.0, 2000.0  # mu N = 480 N
    loads = PRESS + (NodalLoad("upper/bottom", "x", F, 1, spread="area"),)
    cm = model(mesh, st, mu, loads, samples=256)
    p = OperatingPoint(w)
    r = solve_point(cm.hb, p, x0=cm.hb.linear_guess(p, stuck=False))
    assert r.converged, r.reason
    (resp,) = cm.hb.contact_response(r.x, p, True)
    assert np.isin(resp.state, (STICK_SLIP, GROSS_SLIP)).all()
    slipping = resp.flags == SAMPLE_SLIP
    assert slipping.mean() > 0.99  # the reversals' stick arcs: a sample or two
    T = np.linalg.norm(resp.T, axis=1)  # (P, ns) tangential force magnitude
    np.testing.assert_allclose(T[slipping], mu * resp.N[slipping], rtol=1e-9)
    # rigid: every pair's slip (its relative tangential motion along x) is the same, but
    # for the blocks' elastic strains (measured 1.3e-5 of the slip)
    frames = paired_contact(mesh, "interface").frames
    slip = np.einsum("pd,pdn->pn", frames[:, :2, 0], resp.u)
    assert np.abs(slip - slip.mean(axis=0)).max() < 1e-4 * np.abs(slip).max()
    m = RHO * L * L * H
    X = np.hypot(*cm.output_coefficients(r.x, p)[1, 1:3])
    X_rigid = np.sqrt(F**2 - (4 * mu * P * L * L / np.pi) ** 2) / (m * w * w)
    # measured +1.4 %: the stick arc at each reversal (beta = sqrt(4 x_s / X) = 0.035 rad,
    # x_s = mu N / k_s = 2.4e-7 m with k_s the stuck system's stiffness) puts a part of the
    # friction force in phase with the motion, ~ k_s beta^3 / (1.5 pi m w^2) = 1.8 %
    assert X == pytest.approx(X_rigid, rel=2e-2)


def test_contact_jacobian_matches_central_differences_on_an_interpolated_pair():
    """At a state with stick, slip and lift-off over non-matching pairs."""
    mesh = stack(("hexahedron", (2, 2, 2)), ("tetra", (3, 3, 2)))
    st = reduced(mesh, stiffness=False)
    loads = PRESS + (NodalLoad("upper/top", "x", 600.0, 1, spread="area"),
                     NodalLoad("upper/top", "z", 900.0, 1, phase=0.7))
    cm = model(mesh, st, 0.3, loads)
    hb = cm.hb
    p = OperatingPoint(3000.0)
    x = hb.linear_guess(p, stuck=True)
    x += 0.5 * np.random.default_rng(1).normal(size=x.size) * np.abs(x).max()
    states = np.concatenate([r.state for r in hb.contact_response(x, p)])
    assert len(set(states.tolist())) >= 3, states
    R, J, _ = hb.residual(x, p)
    Jfd = fd_residual_jacobian(hb, x, p, 1e-7 * np.abs(x).max())
    # central differences of a piecewise-smooth residual: exact where no sample changes
    # state within +-eps; 1e-5 covers their O(eps^2) error
    assert np.max(np.abs(J - Jfd)) <= 1e-5 * np.max(np.abs(J))


def test_a_block_pressed_on_the_ground():
    """The ground is rigid: the block's top moves by p H / E plus the flat punch's
    compliance, whose stiffness has the block's compliance alone (E* = E / (1 - nu^2))."""
    mesh = stack(None, ("tetra", (4, 4, 2)))
    st = reduced(mesh, stiffness=False)
    a = np.sqrt(L * L / np.pi)
    kn = 2 * a * E  # nu = 0: E* = E
    assert st.patch_stiffness["interface"].total_normal == pytest.approx(kn, rel=1e-12)
    cm = model(mesh, st, 1e3, PRESS)
    assert cm.points["interface"].body_b is None and not len(cm.points["interface"].nodes_b)
    p = OperatingPoint(100.0)
    r = solve_point(cm.hb, p)
    assert r.converged, r.reason
    top = cm.output_coefficients(r.x, p)[0, 0]
    assert top == pytest.approx(-P * H / E - P * L * L / kn, rel=1e-9)


def test_a_contact_declaration_finds_bodies_the_finer_side_and_the_neighbour():
    mesh = two_blocks(("hexahedron", (3, 3, 2)), ("tetra", (7, 7, 2)), (L, L, H), (L, L, H),
                      (0.0, 0.0))
    c = declare_contact(mesh, "i", ("lower/top", "upper/bottom"))  # the finer one made a
    assert (c.body_a, c.set_a, c.body_b, c.set_b) == ("upper", "upper/bottom", "lower",
                                                       "lower/top")
    p = paired_contact(dataclasses.replace(mesh, contacts={"i": c}), "i")
    np.testing.assert_allclose(p.pairing.normals[:, 2], -1.0)  # from the upper into the lower
    assert p.pairing.area == pytest.approx(L * L, rel=1e-12)


@pytest.mark.parametrize("surfaces, kw, message", [
    (("upper/bottom", "nowhere"), {}, "'nowhere' is not a node set"),
    (("upper/bottom",), {}, "expected 2 node-set names"),
    (("upper/bottom", "lower/top"), {"ground": True}, "expected 1 node-set name with ground"),
    (("upper/bottom", "lower/clamp"), {}, "do not face each other"),
    (("upper/bottom", "upper/top"), {}, "a body touches itself only in the neighbouring"),
    (("upper/bottom", "lower/top"), {"neighbour": True}, "is not a cyclic sector body"),
])
def test_a_bad_contact_declaration_is_named(surfaces, kw, message):
    mesh = two_blocks(("hexahedron", (2, 2, 1)), ("hexahedron", (3, 3, 1)), (L, L, H),
                      (L, L, H), (0.0, 0.0))
    with pytest.raises(ValueError, match=message) as err:
        c = declare_contact(mesh, "i", surfaces, **kw)
        paired_contact(dataclasses.replace(mesh, contacts={"i": c}), "i")
    assert "contacts.i" in str(err.value)


def test_a_surface_contact_must_name_sets_and_bodies_of_the_mesh():
    mesh = two_blocks(("hexahedron", (2, 2, 1)), ("hexahedron", (3, 3, 1)))
    with pytest.raises(MeshValidationError, match="no node set 'nowhere'"):
        dataclasses.replace(mesh, contacts={"i": SurfaceContact("i", "upper", "nowhere")})
    with pytest.raises(MeshValidationError, match="body_b and set_b go together"):
        SurfaceContact("i", "upper", "upper/bottom", "lower")


def test_a_neighbour_contact_pairs_the_shroud_interlock_as_its_patch_does():
    """The shrouded blisk's interlock declared between its two named faces with neighbour =
    true: the next sector is found (+1), and the pairs, normals and area are the model's
    own patch's (a structured grid, paired node for node under the sector rotation)."""
    from microslip import geometry

    mesh = geometry.shrouded_blisk()
    c = declare_contact(mesh, "lock", ("contact/shroud/a", "contact/shroud/b"), neighbour=True)
    assert (c.body_a, c.body_b, c.b_sector_offset) == ("blisk", "blisk", 1)
    mesh = dataclasses.replace(mesh, contacts={**mesh.contacts, "lock": c})
    lock, patch = paired_contact(mesh, "lock").pairing, paired_contact(mesh, "shroud").pairing
    assert lock.matching
    partner = lock.nodes_b[lock.weights.indices]  # one partner per pair, node for node
    assert sorted(zip(lock.nodes_a, partner)) == sorted(zip(patch.nodes_a, patch.nodes_b))
    np.testing.assert_allclose(lock.normals, patch.normals, atol=1e-9)
    assert lock.area == pytest.approx(patch.area, rel=1e-9)
    np.testing.assert_allclose(lock.gaps, 0.0, atol=1e-12)


def test_the_part_of_a_surface_beyond_the_other_touches_nothing():
    """The upper block half over the lower one's edge: its bottom's nodes beyond that edge
    (by more than the tolerance, with less than half their area over it) are left out and
    counted, with how far the farthest lies; the others keep the part of their area over
    the lower block, so the contact's area is the overlap but for one row of nodes at the
    edge; side b keeps only the nodes the pairs use (its masters)."""
    mesh = two_blocks(("hexahedron", (4, 4, 1)), ("tetra", (7, 5, 1)), (L, L, H), (L, L, H),
                      (0.5 * L, 0.0))
    c = declare_contact(mesh, "half", ("upper/bottom", "lower/top"))
    p = paired_contact(dataclasses.replace(mesh, contacts={"half": c}), "half")
    x = mesh.points[mesh.node_sets["upper/bottom"], 0]
    beyond = x > L + 1e-12
    assert 0 < p.dropped[0] <= beyond.sum()
    assert p.dropped[1] == pytest.approx(x.max() - L, rel=1e-9)  # a distance in metres
    spacing = L / 7
    assert 0.5 * L * L - spacing * L <= p.pairing.area <= 0.5 * L * L * (1 + 1e-12)
    # averaged points over the same contact keep the count (the run's note) and the area
    averaged = averaged_surfaces(dataclasses.replace(mesh, contacts={"half": c}), "half",
                                 0.012)
    q = paired_contact(averaged, "half")
    assert q.dropped == p.dropped
    assert q.pairing.area == pytest.approx(p.pairing.area, rel=1e-9)
    used = np.unique(p.pairing.weights.indices)
    assert len(used) == len(p.pairing.nodes_b)
    assert mesh.points[p.pairing.nodes_b, 0].min() >= 0.5 * L - L / 4 - 1e-12
