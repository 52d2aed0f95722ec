"""The shrouded blisk's static interlock state against an independent static solve: the
unreduced sector at ND 0 condensed exactly onto the node pairs (its compliance from one
sparse factorization), penalty springs per pair, Coulomb friction by return mapping, the
interference ramped from zero (the path a preload takes). The harmonic balance's order-0
forces at a vanishing excitation are that state; at 1 N the vibration already moves them
(shakedown of the pairs at their friction limit). Without the preload, at speed, the
staggered blades untwist under the centrifugal load and one row of the interlock closes."""

import copy
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from microslip import case as cases
from microslip.app.run import run_case
from microslip.fe import cyclic, fem
from microslip.geometry.mesh import rotation_z
from microslip.results import schema

CASE = Path(__file__).parent.parent / "cases" / "12_shrouded_blisk.toml"


def _static_interlock(mesh, kn, kt, mu, interference, steps=200, speed=0.0):
    """(N (p,), |T| (p,), slipping (p,)) of the pairs at the full interference and the
    rotation ``speed`` [rad/s] (its centrifugal load ramped with the interference)."""
    patch = mesh.contacts["shroud"]
    body = fem.assemble(mesh, "blisk", fem.Material(2.0e11, 0.3, 7850.0), 2)
    sector = cyclic.sector_model(body, fem.node_set(mesh, "blisk/bore"),
                                 mesh.cyclic["blisk"], 0)
    P = sector.expansion.tocsr()
    turn = sp.csr_matrix(rotation_z(patch.b_sector_offset * mesh.cyclic["blisk"].angle))
    n = patch.normal
    e = np.eye(3)[np.argmin(np.abs(n))]
    t1 = (e - (e @ n) * n) / np.linalg.norm(e - (e @ n) * n)
    frame = sp.csr_matrix(np.array([t1, np.cross(n, t1), n]))  # rows t1, t2, n (a into b)
    B = sp.vstack([frame @ (P[body.dofs_of_nodes([a])[0]] - turn @ P[body.dofs_of_nodes([b])[0]])
                   for a, b in zip(patch.nodes_a.ravel(), patch.nodes_b.ravel(),
                                   strict=True)]).tocsr()
    factor = spla.splu(sector.stiffness.tocsc())
    C = B @ factor.solve(B.T.toarray())  # g = g_load - C lambda
    # the pairs' motion under the centrifugal load alone (P^T f: its share on the free DOFs)
    spun = B @ factor.solve(P.T @ fem.centrifugal_load(body) * speed**2)
    p = B.shape[0] // 3

    def law(g, s, d):
        g = g.reshape(p, 3)
        N = np.maximum(kn * (g[:, 2] + d), 0.0)
        T = kt[:, None] * (g[:, :2] - s)
        size = np.linalg.norm(T, axis=1)
        slip = (N > 0) & (size > mu * N)
        T = np.where(slip[:, None], mu * N[:, None] * T / np.maximum(size, 1e-300)[:, None],
                     np.where(N[:, None] > 0, T, 0.0))
        return np.column_stack([T, N]).ravel(), slip

    g, s = np.zeros(3 * p), np.zeros((p, 2))
    for t in np.linspace(0.0, 1.0, steps + 1)[1:]:
        d = t * interference
        for _ in range(60):  # Newton on g - t g_load + C lambda(g) = 0 (numerical tangent)
            lam, _ = law(g, s, d)
            J = np.eye(3 * p) + C @ np.column_stack(
                [(law(g + 1e-12 * e_j, s, d)[0] - lam) / 1e-12 for e_j in np.eye(3 * p)])
            step = np.linalg.solve(J, -(g - t * spun + C @ lam))
            g += step
            if np.abs(step).max() < 1e-15:
                break
        lam, slip = law(g, s, d)
        lam = lam.reshape(p, 3)
        s = np.where(slip[:, None], g.reshape(p, 3)[:, :2] - lam[:, :2] / kt[:, None], s)
    return lam[:, 2], np.linalg.norm(lam[:, :2], axis=1), slip


@pytest.mark.slow
@pytest.mark.parametrize(("interference", "speed", "closed"), [
    (2.0e-5, 0.0, 18),  # the shipped preload: every pair closed
    (0.0, 1500.0, 6),  # no preload: the staggered blade untwists, one row of pairs closes
])
def test_the_interlocks_static_state_is_an_independent_static_solve(tmp_path, interference,
                                                                    speed, closed):
    data = tomllib.loads(CASE.read_text())
    data["assembly"]["contacts"][0]["interference"] = interference
    if speed:
        data["assembly"] |= {"speed": speed, "centrifugal": ["blisk"]}
    (frf,) = data["analysis"]
    frf.update(start=6600.0, stop=6620.0, maps=[], map_types=["status"],
               family={"key": "assembly.excitation", "values": [0.01, 1.0]})
    path = run_case(cases.Case(copy.deepcopy(data), "shroud.toml"), tmp_path,
                    progress=lambda _: None)
    with h5py.File(path) as f:
        assert f.attrs["status"] == "complete"
        kn = f["reduction/contact_stiffness/shroud/normal_n_per_m"][()].ravel()
        kt = f["reduction/contact_stiffness/shroud/tangential_n_per_m"][()].ravel()
        small, large = (f[f"frf/curve_00{i}/patches/shroud/static"][0] for i in (0, 1))
    mesh = cases.Case(data, "shroud.toml").geometry_table.build()
    mu = data["assembly"]["contacts"][0]["mu"]
    N, T, slip = _static_interlock(mesh, kn, kt, mu, interference, speed=speed)
    # at 0.01 N (a vibration ~1e-4 of the static motion) the balance's static forces are
    # the static solve's: measured 3e-4 (preload) and 2e-5 (untwist) of the largest pair's
    # normal load (the vibration's own effect, which grows with it: 3 % at 1 N, preloaded)
    scale = N.max()
    assert np.abs(small[:, 2] - N).max() < 2e-3 * scale
    assert np.abs(np.linalg.norm(small[:, :2], axis=1) - T).max() < 2e-3 * scale
    # the closed pairs at their friction limit: the interlock slid as it closed (the 30 deg
    # notch turns the closing into a sliding force above mu N)
    shut = N > 0
    assert shut.sum() == closed and np.all(slip == shut)
    assert np.abs(T - mu * N).max() < 1e-9 * scale
    if not speed:
        assert np.abs(large[:, 2] - N).max() > 1e-2 * scale  # (at 1 N: moved)


@pytest.mark.slow
def test_the_assemblys_stuck_frequency_is_the_stuck_limits_resonance(tmp_path):
    """A modes analysis of an assembly case gives the reduced assembly's natural frequencies
    with every contact stuck: harmonic 1's first is where the FRF's fully stuck limit,
    solved directly point by point, peaks."""
    data = tomllib.loads(CASE.read_text())
    (frf,) = data["analysis"]
    frf.update(start=6950.0, stop=7150.0, maps=[], map_types=["status"],
               family={"key": "assembly.excitation", "values": [1.0]})
    data["analysis"].append({"name": "modes", "type": "modes", "count": 4, "shapes": False})
    path = run_case(cases.Case(copy.deepcopy(data), "shroud.toml"), tmp_path,
                    progress=lambda _: None)
    with h5py.File(path) as f:
        assert f.attrs["status"] == "complete"
        stuck = f["modes/assembly/order1/stuck_hz"][()]
        free = f["modes/assembly/order1/free_hz"][()]
        limit = f[f"frf/{schema.linear_stuck(0, 1)}"]
        peak = limit["omega"][()][np.argmax(limit["response"][()][:, 0])]
    # the peak of a response with 0.2 % modal damping lies within 4e-6 of the natural
    # frequency; the limit's points around it are 0.12 rad/s apart (1.7e-5)
    assert abs(2 * np.pi * stuck[0] / peak - 1) < 5e-5
    assert free[0] < stuck[0]  # (the interlock stiffens the blades)


@pytest.mark.slow
def test_the_1N_frf_passes_a_square_root_cusp_by_a_longer_step(tmp_path, monkeypatch):
    """The shipped shroud's 1 N FRF meets, near 7056.7 rad/s, a pair whose stuck cycle's
    admissible slider positions shrink to a point (its residual rises as the square root
    of the arc there): every short arclength step and the fixed-frequency crossings fail,
    and the branch used to stop. A step a few times longer lands past it; the branch it
    skips is there: Newton at fixed frequencies inside the leap converges (1.1 min)."""
    from microslip.app.models import AssemblyModels
    from microslip.app.stages import mesh_geometry
    from microslip.app.structure import reduce_structure
    from microslip.case import curve_variants
    from microslip.solve import arclength, response
    from microslip.solve import continuation as cont

    case = cases.load(CASE)
    spec = case.analysis_specs[0]
    variant = next(iter(curve_variants(case, spec)))[0]
    assert variant.data["assembly"]["excitation"] == 1.0
    mesh = mesh_geometry(case.geometry_table, tmp_path, progress=lambda s: None,
                         pictures=False)
    structure = reduce_structure(mesh, variant.data["reduction"], None,
                                 cases.harmonics(variant).orders, progress=lambda s: None)
    hb = AssemblyModels(mesh, structure).model(variant)
    base = cases.operating_point(variant, spec.omega)
    settings = cases.settings(variant)

    def sweep():
        return response.sweep(hb, "frequency", spec.start, spec.stop, base, settings=settings)

    leaps = []
    leap = arclength._leap

    def recorded(fun, x, lam, *args):
        out = leap(fun, x, lam, *args)
        leaps.append((lam, x, out[0]))
        return out

    monkeypatch.setattr(arclength, "_leap", recorded)
    branch = sweep().branch
    landed = [(lam, x) for lam, x, o in leaps if o is not None]  # (early ones may miss)
    assert branch.complete and landed
    lam0, x0 = landed[0]
    i = int(np.flatnonzero(branch.values == lam0)[0])
    lam1, x1 = branch.values[i + 1], branch.x[i + 1]
    assert 0 < lam1 - lam0 < 2.0  # rad/s: past the cusp, not over the resonance (7041)
    fun = response.problem(hb, base, "frequency")
    xs, fs = response.scales(hb, base)
    for f in (0.25, 0.5, 0.75):  # the skipped stretch: solutions at every frequency
        r = cont.newton(fun, x0 + f * (x1 - x0), lam0 + f * (lam1 - lam0), x_scale=xs,
                        f_scale=fs, settings=settings)
        assert r.converged
    monkeypatch.setattr(arclength, "MAX_LEAPS", 0)  # without the leaps: stopped there
    monkeypatch.setattr(arclength, "EARLY_LEAPS", 0)
    stopped = sweep().branch
    assert stopped.status == "stopped" and abs(stopped.values[-1] - lam0) < 1e-6 * lam0
