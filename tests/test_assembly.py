"""Reduced FE bodies joined by friction patches (the blisk sector and its wedge damper) in
the cyclic harmonic balance: linear limits solved directly, the static balance of the
damper, the energy balance, derivatives against finite differences, and the cyclic sector
against the full-disk model (the test of the neighbour-sector phase and rotation)."""

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from derivatives import fd_residual_jacobian
from scipy.optimize import linear_sum_assignment

from microslip import geometry
from microslip.app import structure
from microslip.assembly.join import join
from microslip.assembly.spec import AssemblySpec, NodalLoad, Output, PatchFriction
from microslip.case.reduction_table import body_specs
from microslip.fe import cyclic, fem
from microslip.fourier import Harmonics
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point, sweep

NS = 6
SPEED = 1000.0  # rad/s: centrifugal load on the damper, ~2 kN: contacts well closed
# The coarsest sector with 3 x 2 node pairs per flank; linear tets keep the full-disk
# reference (six sectors, six dampers) to a few seconds. Both models use the same elements.
GEOMETRY = dict(sectors=NS, size=0.03, blade_size=0.012, contact_n_axial=3, contact_n_flank=2)
REDUCTION = {"modes": "auto", "f_max": 1500.0, "order": 1,
             "damping": {"modal_ratios": 0.005}}


@pytest.fixture(scope="module")
def sector():
    mesh = geometry.blisk_sector(**GEOMETRY)
    red = {**REDUCTION, "nodal_diameters": [0, 1]}
    return mesh, structure.reduce_structure(mesh, red, None, progress=lambda s: None)


def spec(mu, eo=1, amplitude=1.0, contacts=("damper_left", "damper_right"), speed=SPEED,
         elements="2D", anchor=1e-3):
    return AssemblySpec(
        contacts=tuple(PatchFriction(p, mu, elements=elements) for p in contacts),
        engine_order=eo, loads=(NodalLoad("blisk/excitation", "tangential", amplitude),),
        outputs=(Output("tip", "blisk/response", "tangential"),), speed=speed,
        centrifugal=("damper",) if contacts else (),
        mass_bodies=("damper",) if contacts else (), static_anchor=anchor)


def model(sector, mu, h=None, **kw):
    mesh, red = sector
    return join(mesh, red.models, red.patch_stiffness, spec(mu, **kw),
                  h or Harmonics.up_to(1, 64))


def first_bending(sector) -> float:
    """rad/s of the ND 1 first bending of the free blisk (the reduced sector alone)."""
    return 2 * np.pi * sector[1].frequencies["blisk", 1][0]


def solved(cm, w, x0=None):
    p = OperatingPoint(w)
    r = solve_point(cm.hb, p, x0=x0)
    assert r.converged, r.reason
    return r.x, p


@pytest.mark.parametrize("factor", [0.9, 1.0, 1.1])
def test_vanishing_friction_equals_the_normal_springs(sector, factor):
    """mu = 0, contacts closed by the centrifugal load: the FRF is that of the bodies joined
    by the normal springs alone, solved directly as a linear system."""
    cm = model(sector, 0.0)
    x, p = solved(cm, factor * first_bending(sector))
    assert all(np.all(r.N.min(axis=1) > 0) for r in cm.hb.contact_response(x, p, True))
    out, ref = cm.output_coefficients(x, p), cm.linear_outputs(p, "normal")
    # Newton stops at 1e-9 of the force scale; the linear solve is exact to round-off
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-7 * np.abs(ref).max())


@pytest.mark.parametrize("factor", [0.9, 1.0, 1.1])
def test_unreachable_friction_limit_equals_the_stuck_system(sector, factor):
    """mu far above |T|/N: every contact sticks and the FRF is the linear stuck system
    (tangential and normal springs; the predictor T0 = kt u0 of eq. 26)."""
    cm = model(sector, 1e4)
    x, p = solved(cm, factor * first_bending(sector))
    assert all(np.all(r.state == 0) for r in cm.hb.contact_response(x, p))
    out, ref = cm.output_coefficients(x, p), cm.linear_outputs(p, "stuck")
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-7 * np.abs(ref).max())


def test_no_damper_is_the_free_blisk(sector):
    """Without the damper the model is linear (no contact DOF) and equals the blisk alone;
    the damper, stuck, moves the resonance up (it stiffens the platforms)."""
    mesh, red = sector
    cm = join(mesh, {"blisk": red.models["blisk"]}, red.patch_stiffness, spec(0.5, contacts=()),
                Harmonics.up_to(1, 64))
    assert cm.hb.n_unknowns == 0
    with_damper = model(sector, 0.5)
    ws = first_bending(sector) * np.array([0.95, 1.0, 1.05])
    for w in ws:
        p = OperatingPoint(w)
        want = with_damper.linear_outputs(p, "free")
        # the same solves in another order: rounding of the largest coefficient (a static
        # one 1e-4 of it is not held to its own 1e-12)
        np.testing.assert_allclose(cm.output_coefficients(np.zeros(0), p), want, rtol=0,
                                   atol=1e-12 * np.max(np.abs(want)))
    r = sweep(cm.hb, "frequency", ws[0], ws[-1], OperatingPoint(ws[0]))
    w_free = r.peak(cm.outputs["tip"])[0]
    assert w_free == pytest.approx(first_bending(sector), rel=2e-3)  # the blisk's own mode


@pytest.mark.parametrize("mass, anchor", [(1.0, 0.0), (3.0, 0.0), (3.0, 1e-3)])
def test_static_contact_forces_balance_the_centrifugal_load(sector, mass, anchor):
    """Order 0 of the damper's equilibrium: its centrifugal force (scaled with its mass by
    the mass multiplier) and the static contact forces on it sum to zero (the rigid
    translations are in its Craig-Bampton basis); with the static anchor, its springs'
    forces ``anchor kt g0`` on each pair's mean tangential slip join the contact forces."""
    mesh, red = sector
    cm = model(sector, 0.5, anchor=anchor)
    p = OperatingPoint(first_bending(sector), mass_multiplier=mass)
    r = solve_point(cm.hb, p)
    assert r.converged, r.reason
    x = r.x
    damper = red.models["damper"][0]
    centrifugal = mass * SPEED**2 * np.array([damper.loads["centrifugal"][damper.dof_index(
        damper.master_nodes)[:, j]].sum().real for j in range(3)])
    total = np.zeros(3)
    gaps = cm.hb.relative_displacements(x)
    for c, r, g in zip(cm.hb.contacts, cm.hb.contact_response(x, p), gaps):
        frames = cm.points[c.name].frames  # rows t1, t2, n; forces act on body a (damper)
        forces = r.forces[:, :, 0].copy()
        forces[:, :2] += anchor * c.elements.kt * g[:, :2, 0]
        total -= np.einsum("pji,pj->i", frames, forces)
    assert np.linalg.norm(centrifugal) > 100.0  # a load worth balancing (N)
    # Newton tolerance 1e-9 of the force scale, summed over 12 pairs: far below 1e-6
    assert np.linalg.norm(total + centrifugal) <= 1e-6 * np.linalg.norm(centrifugal)


@pytest.mark.parametrize("factor", [0.985, 0.995, 1.015])
def test_energy_balance_at_points_around_the_resonance(sector, factor):
    """The fast version of the sweep below: the same balance at three frequencies."""
    cm = model(sector, 0.5, amplitude=50.0)
    p = OperatingPoint(factor * first_bending(sector))
    r = solve_point(cm.hb, p)
    assert r.converged, r.reason
    e = cm.hb.energy_balance(r.x, p)
    # as below: what is left is the Newton residual (1e-9 of the forces) times the motion
    assert e["excitation"] == pytest.approx(e["viscous"] + e["friction"] + e["normal"],
                                            rel=1e-6)
    assert e["friction"] > 0.0


@pytest.mark.slow
def test_energy_balance_along_a_sweep(sector):
    """Work of the excitation per cycle = friction + linear damping (+ the normal springs'
    work, zero up to the sampling) at every point of an FRF through the resonance."""
    cm = model(sector, 0.5, amplitude=50.0)
    w = first_bending(sector)
    r = sweep(cm.hb, "frequency", 0.97 * w, 1.03 * w, OperatingPoint(0.97 * w))
    assert r.branch.complete, r.branch.message
    for i in range(0, len(r), max(1, len(r) // 8)):
        e = r.energy(i)
        # the sampled contact forces do work on the sampled motion exactly as the balance
        # sees them; what is left is the Newton residual (1e-9 of the forces) times motion
        assert e["excitation"] == pytest.approx(e["viscous"] + e["friction"] + e["normal"],
                                                rel=1e-6)
    assert max(r.energy(i)["friction"] for i in range(len(r))) > 0.0


def test_jacobian_matches_central_differences(sector):
    """At a state with stick, slip and lift-off across the pairs (a large excitation near
    the resonance, perturbed), and for the frequency derivative with the centrifugal load
    tied to the speed w / EO."""
    w = first_bending(sector)
    cm = model(sector, 0.5, amplitude=400.0, speed=None)
    hb = cm.hb
    p = OperatingPoint(w)
    x = hb.linear_guess(p, stuck=True)
    x += 0.3 * np.random.default_rng(3).normal(size=x.size) * np.abs(x).max()
    states = np.concatenate([r.state for r in hb.contact_response(x, p)])
    assert len(set(states.tolist())) >= 3, states  # a mixed state
    R, J, _ = hb.residual(x, p)
    Jfd = fd_residual_jacobian(hb, x, p, 1e-6 * np.abs(x).max())
    # central differences of a piecewise-smooth residual: exact where no sample changes
    # state within +-eps, which holds for this state; 1e-5 covers their O(eps^2) error
    assert np.max(np.abs(J - Jfd)) <= 1e-5 * np.max(np.abs(J))
    # the parameters: frequency (speed w / EO: the centrifugal load follows) and the damper's
    # mass multiplier (its inertia and its centrifugal load)
    for parameter, value in (("frequency", w), ("mass", 2.0)):
        q = p.set(parameter, value)
        dR = hb.residual(x, q, parameter)[2]
        dv = 1e-6 * value
        dfd = (hb.residual(x, q.set(parameter, value + dv), jacobian=False)[0]
               - hb.residual(x, q.set(parameter, value - dv), jacobian=False)[0]) / (2 * dv)
        assert np.max(np.abs(dR - dfd)) <= 1e-5 * np.max(np.abs(dR))


@pytest.fixture(scope="module")
def full_disk(sector):
    return _full_disk(sector)


def _full_disk(sector):
    """The same blisk as Ns rotated copies: one blisk body, Ns dampers, 2 Ns plain patches."""
    mesh, _ = sector
    full = geometry.full_disk(mesh)
    sets = {s: [f"blisk/{s}#{k}" for k in range(NS)] for s in ("bore", "excitation",
                                                                "response")}
    red = {**REDUCTION, "nodal_diameters": [0], "bodies": {"blisk": {
        "clamped": sets["bore"], "masters": sets["excitation"] + sets["response"],
        "recovery": []}}}
    return full, structure.reduce_structure(full, red, None, progress=lambda s: None)


def full_disk_model(full_disk, mu, eo, h, amplitude=1.0):
    """Loads on every blade with the engine order's phase, sector k: k EO 2 pi / Ns."""
    full, red = full_disk
    dampers = tuple(b for b in full.bodies if b.startswith("damper"))
    phi = 2 * np.pi / NS
    s = AssemblySpec(
        contacts=tuple(PatchFriction(p, mu) for p in sorted(full.contacts)), engine_order=eo,
        loads=tuple(NodalLoad(f"blisk/excitation#{k}", "tangential", amplitude, 1,
                              k * eo * phi)
                    for k in range(NS)),
        outputs=(Output("tip", "blisk/response#0", "tangential"),), speed=SPEED,
        centrifugal=dampers, mass_bodies=dampers)
    return join(full, red.models, red.patch_stiffness, s, h)


@pytest.mark.parametrize("eo", [1, 5])  # ND 1 forward, and backward (conjugated matrices)
@pytest.mark.parametrize("mu, amplitude, rtol", [
    # stuck: both models span the same space, agreement 1e-9 (measured); the wrong wave
    # differs by 2e-5 here (on 45 deg flanks the damper passes little force between
    # neighbouring platforms), so 1e-7 is what tells a wrong phase or rotation apart
    (1e4, 1.0, 1e-7),
    # microslip at the resonance: agreement 8e-6 (measured; Newton stops at 1e-9 of the
    # forces, and the response is ~100x the static one there)
    (0.5, 15.0, 1e-4)])
def test_cyclic_sector_equals_the_full_disk(sector, full_disk, eo, mu, amplitude, rtol):
    """The sector with the neighbour's phase exp(i n EO phi) and rotation against Ns copies
    joined node for node (six dampers, twelve plain patches): first-harmonic tip amplitudes
    at three frequencies through the resonance; and the opposite wave as a negative control
    (the test can fail)."""
    h = Harmonics.up_to(1, 64)
    ref = full_disk_model(full_disk, mu, eo, h, amplitude)
    cases = [(model(sector, mu, eo=eo, h=h, amplitude=amplitude), rtol, True)]
    if mu > 1:
        cases.append((model(sector, mu, eo=NS - eo, h=h, amplitude=amplitude), 1e-6, False))
    w0 = first_bending(sector)
    amp = lambda c: np.hypot(c[0, 1], c[0, 2])  # noqa: E731  first-harmonic amplitude
    for cyc, tol, same in cases:
        err = max(abs(amp(cyc.output_coefficients(*solved(cyc, w)))
                      / amp(ref.output_coefficients(*solved(ref, w))) - 1)
                  for w in (0.98 * w0, w0, 1.02 * w0))
        assert (err <= tol) == same, err


@pytest.fixture(scope="module")
def averaged():
    """The sector and its full disk with each contact point averaging a cell of a finer
    flank mesh (every point an averaged master; full disk: the averages copied)."""
    mesh = geometry.blisk_sector(**GEOMETRY, contact_size=0.004)
    assert len(mesh.averaged_points) == 4 * 6
    sector = mesh, structure.reduce_structure(mesh, {**REDUCTION, "nodal_diameters": [0, 1]},
                                              None, progress=lambda s: None)
    return sector, _full_disk(sector)


@pytest.mark.parametrize("mu, amplitude, rtol", [(1e4, 1.0, 1e-7), (0.5, 15.0, 1e-4)])
def test_averaged_contact_points_cyclic_sector_equals_the_full_disk(averaged, mu, amplitude,
                                                                    rtol):
    """As test_cyclic_sector_equals_the_full_disk (same tolerances, same reasons), with the
    contact points averages of the flank mesh: the averages' weights go through the cyclic
    expansion and the neighbour's rotation as the nodes do."""
    sector, full = averaged
    h = Harmonics.up_to(1, 64)
    cyc = model(sector, mu, h=h, amplitude=amplitude)
    ref = full_disk_model(full, mu, 1, h, amplitude)
    w0 = first_bending(sector)
    amp = lambda c: np.hypot(c[0, 1], c[0, 2])  # noqa: E731  first-harmonic amplitude
    err = max(abs(amp(cyc.output_coefficients(*solved(cyc, w)))
                  / amp(ref.output_coefficients(*solved(ref, w))) - 1)
              for w in (0.98 * w0, w0, 1.02 * w0))
    assert err <= rtol, err


@pytest.fixture(scope="module")
def named():
    """The sector with its flanks declared between named surfaces (an imported model's
    contacts: the left one node to node, the right one, on the neighbour's platform,
    points averaging patches of it), and its full disk (the sector's pairs turned onto
    every copy)."""
    import dataclasses

    from microslip.geometry.averaging import averaged_surfaces
    from microslip.geometry.pairing import declare_contact

    mesh = geometry.blisk_sector(**GEOMETRY)
    contacts = {name: declare_contact(mesh, name, (f"contact/{name}/damper",
                                                   f"contact/{name}/blisk"),
                                      neighbour=name == "damper_right", spread="nodes")
                for name in ("damper_left", "damper_right")}
    # 4 points over the flank's 6 nodes (2 of them patches of 2 nodes)
    mesh = averaged_surfaces(dataclasses.replace(mesh, contacts=contacts), "damper_right",
                             0.006)
    assert len(mesh.contacts["damper_right"].nodes_a) == 4
    sector = mesh, structure.reduce_structure(mesh, {**REDUCTION, "nodal_diameters": [0, 1]},
                                              None, progress=lambda s: None)
    return sector, _full_disk(sector)


@pytest.mark.parametrize("mu, amplitude, rtol", [(1e4, 1.0, 1e-7), (0.5, 15.0, 1e-4)])
def test_named_surface_contacts_cyclic_sector_equals_the_full_disk(named, mu, amplitude, rtol):
    """As test_cyclic_sector_equals_the_full_disk (same tolerances, same reasons), with the
    contacts between named surfaces: each copy keeps the sector's pairs, their order (the
    per-pair stiffness follows it), weights and areas, its nodes and frames turned."""
    from microslip.geometry.mesh import rotation_z
    from microslip.geometry.pairing import paired_contact

    (mesh, _), (full, _) = named
    phi = 2 * np.pi / NS
    for name in mesh.contacts:
        p = paired_contact(mesh, name)
        for k in range(NS):
            q = paired_contact(full, f"{name}#{k}")
            R = rotation_z(k * phi)
            np.testing.assert_allclose(full.points[q.pairing.nodes_a],
                                       mesh.points[p.pairing.nodes_a] @ R.T, atol=1e-12)
            assert (q.pairing.weights != p.pairing.weights).nnz == 0
            np.testing.assert_array_equal(q.pairing.areas, p.pairing.areas)
            np.testing.assert_allclose(q.frames, p.frames @ R.T, atol=1e-14)
            # the map's cells: each copied node stands in its sector node's point
            (nodes, owner, _), (own, owner_s, _) = q.map_cells(), p.map_cells()
            if owner is not None:
                mapped = geometry.disk_node_map(mesh)[k][own]
                assert dict(zip(nodes.tolist(), owner.tolist())) == dict(
                    zip(mapped.tolist(), owner_s.tolist()))
    h = Harmonics.up_to(1, 64)
    cyc = model(named[0], mu, h=h, amplitude=amplitude)
    ref = full_disk_model(named[1], mu, 1, h, amplitude)
    w0 = first_bending(named[0])
    amp = lambda c: np.hypot(c[0, 1], c[0, 2])  # noqa: E731  first-harmonic amplitude
    err = max(abs(amp(cyc.output_coefficients(*solved(cyc, w)))
                  / amp(ref.output_coefficients(*solved(ref, w))) - 1)
              for w in (0.98 * w0, w0, 1.02 * w0))
    assert err <= rtol, err


def test_a_turned_copy_turns_the_frames_of_near_axial_normals(named):
    """A copy's frames are the sector's turned, also where the default frame of a normal
    within 25 deg of the axis takes +x as its first direction, which does not turn: the
    copy's own default frames differ there (the test can fail)."""
    import dataclasses

    from microslip.geometry.mesh import rotation_z
    from microslip.geometry.pairing import paired_contact, turned_copy

    (mesh, _), _ = named
    p = paired_contact(mesh, "damper_left")
    k = len(p.pairing.nodes_a)
    axial = np.tile([0.2, 0.1, 1.0] / np.linalg.norm([0.2, 0.1, 1.0]), (k, 1))
    p = dataclasses.replace(p, pairing=dataclasses.replace(p.pairing, normals=axial))
    identity = np.arange(len(mesh.points))
    angle = 2 * np.pi / NS
    q = turned_copy(p, "copy", p.body_a, p.body_b, identity, identity, angle)
    R = rotation_z(angle)
    np.testing.assert_allclose(q.pairing.normals, axial @ R.T, atol=1e-15)
    np.testing.assert_allclose(q.frames, p.frames @ R.T, atol=1e-14)
    untouched = dataclasses.replace(q, reference=None)
    assert np.abs(untouched.frames - q.frames).max() > 0.5


def test_a_turned_copy_keeps_each_pair_and_map_cell_through_any_node_numbering(named):
    """A copy's node numbers need not follow the sector's order (a copy's left cyclic face
    takes the previous copy's numbers): through reversed and rolled numberings, every pair
    keeps its place (the per-pair stiffness follows it) and every facet node its averaged
    point, in the pairs and in the copied definition (the owner re-sorted with its nodes)."""
    from microslip.geometry.full_disk import _Copy, _named_copy
    from microslip.geometry.pairing import _averaged_pairs, paired_contact, turned_copy

    (mesh, _), _ = named
    n = len(mesh.points)
    map_a, map_b = np.arange(n)[::-1].copy(), np.roll(np.arange(n), 7)
    c = mesh.contacts["damper_right"]
    p = paired_contact(mesh, "damper_right")
    q = turned_copy(p, "copy", c.body_a, c.body_b, map_a, map_b, 0.3)
    np.testing.assert_array_equal(q.pairing.nodes_a, map_a[p.pairing.nodes_a])
    np.testing.assert_array_equal(q.pairing.nodes_b, map_b[p.pairing.nodes_b])
    nodes, owner, faces = p.map_cells()
    place = _Copy("copy", c.body_a, c.body_b, 0, 1, map_a, map_b, 0.3)
    defined = _averaged_pairs(_named_copy(c, place))
    for copy in (q, defined):
        got_nodes, got_owner, got_faces = copy.map_cells()
        assert np.all(np.diff(got_nodes) > 0)  # sorted, as map_cells' indices assume
        assert dict(zip(got_nodes.tolist(), got_owner.tolist())) == dict(
            zip(map_a[nodes].tolist(), owner.tolist()))
        np.testing.assert_array_equal(np.where(got_faces < 0, -1, got_nodes[got_faces]),
                                      np.where(faces < 0, -1, map_a[nodes[faces]]))
    np.testing.assert_allclose(defined.frames, q.frames, atol=1e-14)  # (not near-axial)


def test_a_damper_nothing_holds_is_reported_not_solved(sector):
    """No centrifugal load and zero interference: nothing presses the damper on the flanks,
    its static position is undetermined (the order-0 block singular). The solve must stop
    saying so, never return NaN or a silent non-convergence."""
    cm = model(sector, 0.5, speed=0.0, anchor=0.0)
    r = solve_point(cm.hb, OperatingPoint(first_bending(sector)))
    assert not r.converged
    assert np.all(np.isfinite(r.x))
    assert "static (order-0) problem is singular" in r.reason
    assert "centrifugal load" in r.reason


def _full_hill(hb, x, p):
    """(J, Delta_1, Delta_2): the Hill problem of the reduced model assembled explicitly on
    every DOF of every order (real and imaginary parts of each order's amplitudes side by
    side; order 0 real), the contact forces' Jacobian taken from the balance's as J minus
    its condensed linear part. The reference of the condensed shift-and-invert."""
    h, lin = hb.harmonics, hb.linear
    _, Jc, _ = hb.residual(x, p)
    Jc = Jc - h.real_matrix(hb.condensed(p).S)
    blocks, starts, at = [], [], 0
    for o, D, M, C in zip(h.orders, lin.dynamic_stiffness(p), lin.mass(p), lin.C):
        mats = [D, C + 2j * o * p.omega * M, M]
        # a complex operator on z = u + i v as a real one on [u, v]
        blocks.append([A.real if o == 0 else np.block([[A.real, -A.imag], [A.imag, A.real]])
                       for A in mats])
        starts.append(at)
        at += blocks[-1][0].shape[0]
    J, d1, d2 = (np.zeros((at, at)) for _ in range(3))
    for s, b in zip(starts, blocks):
        n = b[0].shape[0]
        for out, A in zip((J, d1, d2), b):
            out[s:s + n, s:s + n] = A
    # contact unknown (dof, coefficient) -> its place: X_n = a_n - i b_n
    place, sign = np.zeros(Jc.shape[0], dtype=int), np.ones(Jc.shape[0])
    nc = h.n_coeffs
    for k, o in enumerate(h.orders):
        n = lin.sizes[k]
        for d_i, d in enumerate(hb.dofs):
            if o == 0:
                place[d_i * nc] = starts[k] + d
                continue
            j = h.dynamic_orders.index(o)
            place[d_i * nc + h.cos_index[j]] = starts[k] + d
            place[d_i * nc + h.sin_index[j]] = starts[k] + n + d
            sign[d_i * nc + h.sin_index[j]] = -1.0
    J[np.ix_(place, place)] += sign[:, None] * Jc * sign[None, :]
    return J, d1, d2


@pytest.mark.parametrize("mu, factor", [(1e4, 1.0), (0.3, 1.0), (0.3, 1.01)])
def test_hill_exponents_of_the_reduced_model(sector, mu, factor, monkeypatch):
    """The condensed shift-and-invert (dense, and ARPACK) against the quadratic eigenvalues
    of the Hill problem assembled on every DOF of every order; stuck (mu = 1e4), against
    the eigenvalues of the linear stuck system per order, shifted by -i n w (the closed
    form of a linear system's exponents). Within the disc |lambda| < 0.45 w (the edge of
    the strip is where the truncated copies differ); to 1e-8 w (ARPACK's 1e-10 relative
    tolerance on 1 / lambda, and the dense eigensolver's round-off on ~500 unknowns)."""
    from microslip.solve import stability as st

    cm = model(sector, mu, amplitude=20.0)
    w = factor * first_bending(sector)
    x, p = solved(cm, w)
    hb = cm.hb
    J, d1, d2 = _full_hill(hb, x, p)
    n = J.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-J, -d1]])
    B = np.block([[np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), d2]])
    ref = sla.eigvals(A, B)
    ref = ref[np.isfinite(ref)]

    def disc(lam):
        return lam[(np.abs(lam) < 0.45 * w) & (np.abs(lam.imag) <= 0.5 * w)]

    def paired(got, want):
        # each exponent with its nearest reference (a conjugate pair's real parts differ by
        # round-off, so sorting by real part alone may swap the pair's members)
        assert got.size == want.size, (got, want)
        rows, cols = linear_sum_assignment(np.abs(got[:, None] - want[None, :]))
        return got[rows], want[cols]

    expected = disc(ref)
    assert expected.size >= 2
    for dense in (True, False):
        monkeypatch.setattr(st, "DENSE", 10**6 if dense else 0)
        got, want = paired(disc(st.hill_stability(hb, x, p).exponents), expected)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-8 * w)
    if mu == 1e4:  # stuck: the linear system's own eigenvalues s = lambda + i n w, per order
        lin, count = hb.linear, 0
        for o, K, M, C in zip(hb.harmonics.orders, lin.K, lin.mass(p), lin.C):
            Ks = K.copy()
            Ks[:lin.n_dof, :lin.n_dof] += hb.stick_stiffness(o)
            s0, k = 1j * o * w, K.shape[0]
            # the pencil expanded about s = i n w; its QZ eigenvalues (accurate to some
            # 1e-6 w: K ~ 1e9 N/m against M ~ 1 kg) count the exponents in the disc
            lam = sla.eigvals(
                np.block([[np.zeros((k, k)), np.eye(k)], [-(Ks + s0 * C + s0**2 * M),
                                                          -(C + 2 * s0 * M)]]),
                np.block([[np.eye(k), np.zeros((k, k))], [np.zeros((k, k)), M]]))
            near = disc(np.concatenate([lam, np.conj(lam)]) if o else lam)
            count += near.size
            for e in near:  # each has a Hill exponent whose stiffness is singular
                got = expected[np.argmin(np.abs(expected - e))]
                assert abs(got - e) < 1e-5 * w
                dyn = [Ks + (s0 + z) * C + (s0 + z) ** 2 * M for z in (got, np.conj(got))]
                sv = [np.linalg.svd(d, compute_uv=False) for d in dyn]
                assert min(v[-1] / v[0] for v in sv) < 1e-12  # round-off of ~1e9 entries
        assert count == expected.size


def _unreduced_limit(sector, nd: int, stuck: bool, count: int) -> np.ndarray:
    """(count,) the lowest natural frequencies [Hz] of the unreduced sector at ND ``nd``:
    the bodies' FE sector models (the blisk's bore clamped, cyclic at ``nd``; the damper
    free) with every contact pair joined by its stick springs (kn along the patch normal,
    kt across it) when ``stuck``, the cyclic blisk alone otherwise. Built from the mesh
    contract, not from the join: a pair on the neighbouring sector moves as the blisk's
    own node turned by T, the sector's face-to-face map read off its expansion."""
    mesh, red = sector
    table = {**REDUCTION, "nodal_diameters": [0, 1]}
    models, bodies = {}, {}
    for s in body_specs(mesh, table):
        bodies[s.body] = fem.assemble(mesh, s.body, s.material, s.order)
        models[s.body] = cyclic.sector_model(bodies[s.body], fem.node_sets_union(
            mesh, list(s.clamped_sets)), mesh.cyclic.get(s.body), nd)
    names = ["blisk", "damper"] if stuck else ["blisk"]
    K = sp.block_diag([models[b].stiffness for b in names], format="csr").astype(complex)
    M = sp.block_diag([models[b].mass for b in names], format="csr").astype(complex)
    if stuck:
        start = dict(zip(names, np.cumsum([0, *(models[b].n_free for b in names)]),
                         strict=False))

        def rows(body: str, nodes) -> sp.csr_matrix:  # (3 len(nodes), n) u of those nodes
            P = models[body].expansion[bodies[body].dofs_of_nodes(nodes).ravel()]
            out = sp.lil_matrix((P.shape[0], K.shape[0]), dtype=complex)
            out[:, start[body]: start[body] + P.shape[1]] = P
            return out.tocsr()

        cyc = mesh.cyclic["blisk"]
        free = [i for i in range(len(cyc.left))
                if abs(rows("blisk", cyc.left[i: i + 1])).sum() > 0]
        left, right = (rows("blisk", f[free[0]: free[0] + 1]).toarray()
                       for f in (cyc.left, cyc.right))
        turn = right @ np.linalg.pinv(left)  # (3, 3) the next sector's u = turn u
        for name, patch in mesh.contacts.items():
            stiff = red.patch_stiffness[name]
            n = np.asarray(patch.normal) / np.linalg.norm(patch.normal)
            for a, b, kn, kt in zip(patch.nodes_a.ravel(), patch.nodes_b.ravel(),
                                    stiff.normal.ravel(), stiff.tangential.ravel(),
                                    strict=True):
                ub = rows(patch.body_b, [b])
                if patch.b_sector_offset:
                    ub = sp.csr_matrix(np.linalg.matrix_power(turn, patch.b_sector_offset)) @ ub
                D = rows(patch.body_a, [a]) - ub
                S = kt * np.eye(3) + (kn - kt) * np.outer(n, n)
                K = K + D.conj().T @ sp.csr_matrix(S) @ D
    lam = spla.eigsh(K.tocsc(), count, M.tocsc(), sigma=-1.0, which="LM")[0]
    return np.sqrt(np.sort(lam.real)) / (2 * np.pi)


@pytest.fixture(scope="module")
def rich_sector(sector):
    """The same sector reduced with fixed-interface modes to 20 kHz (f_max 1500 Hz above)."""
    mesh, _ = sector
    red = {**REDUCTION, "f_max": 20000.0, "nodal_diameters": [0, 1]}
    return mesh, structure.reduce_structure(mesh, red, None, progress=lambda s: None)


@pytest.mark.parametrize("eo", [1, 6])  # harmonic 1 at ND 1 (complex) and ND 0 (real)
def test_the_assemblys_linear_frequencies_against_the_unreduced_assembly(sector, rich_sector,
                                                                         eo):
    """The reduced assembly's stuck and free natural frequencies (the modes analysis'
    assembly table) against the unreduced FE bodies joined by the same stick springs: a
    Ritz bound, and close by the Craig-Bampton truncation alone (every contact node a
    master), which more modes close."""
    nd = eo % NS
    for springs in ("stuck", "free"):
        exact = _unreduced_limit(sector, nd, springs == "stuck", 6)
        errors = [model(s, 0.5, eo=eo).linear_frequencies(OperatingPoint(1.0), 1, springs, 6)
                  / exact - 1 for s in (sector, rich_sector)]
        # Ritz: each reduced basis spans a subspace, so no frequency falls below the
        # unreduced one (-1e-9: the eigensolvers' round-off)
        assert all(np.all(e > -1e-9) for e in errors)
        # modes to 20 kHz: measured 3e-6 (first) to 2.3e-4 (sixth, ~10.6 kHz); to 1.5 kHz
        # (the fixture's f_max, below the first stuck mode): 1.5e-2 to 0.27. The neighbour's
        # opposite phase moves the unreduced ones by -1.7e-3 to -0.14 (measured)
        assert np.all(errors[1] < 5e-4)
        assert np.all(errors[1] < errors[0])


@pytest.mark.slow  # two backbones, the full disk's on 1296 unknowns (7 s)
def test_a_nonlinear_mode_of_the_sector_is_the_full_disk_s(sector, full_disk):
    """The nonlinear mode of the cyclic sector against the same mode of the full disk
    (six sectors and dampers joined node for node), ND 0 (engine order Ns), contacts
    stuck and slipping: natural frequency and self-excitation agree to 1e-10 at levels of
    equal tip amplitude (measured 3e-11, the Newton tolerance of both). ND 0 because its
    mode is single: at ND 1 the full disk has a pair (sin and cos waves), any mix of which
    is a linear mode, and its nonlinear mode drifts from the travelling wave the sector
    computes (the stuck levels still agree to 1e-11 there)."""
    from microslip.solve.nonlinear_modes import ModalBalance, backbone

    h = Harmonics.up_to(1, 64)
    cyc = model(sector, 0.5, eo=NS, h=h, amplitude=15.0)
    ref = full_disk_model(full_disk, 0.5, NS, h, 15.0)
    w0 = first_bending(sector)
    modes, tips = [], []
    for cm in (cyc, ref):
        modal = ModalBalance(cm.hb, OperatingPoint(w0))
        start = modal.linear_modes(1)[0]  # ND 0 has the lowest bending (the disk's stiffest)
        tip = abs(np.asarray(cm.outputs["tip"]) @ start.shape[:cm.hb.linear.n_dof])
        modes.append(backbone(modal, start, (1e-6 / tip, 3e-3 / tip)))
        tips.append(tip)
    sector_mode, disk_mode = modes
    assert sector_mode.status == disk_mode.status == "complete"
    assert sector_mode.xi.max() > 1.0005 * sector_mode.xi[0]  # the contacts slip
    for a in sector_mode.amplitude[::4]:
        _, w, xi = sector_mode.at(a)
        _, w_disk, xi_disk = disk_mode.at(a * tips[0] / tips[1])  # the same tip amplitude
        assert w_disk == pytest.approx(w, rel=1e-10)
        assert xi_disk == pytest.approx(xi, rel=1e-10)
