"""The shrouded blisk's static interlock state against an independent static solve: the
unreduced sector at ND 0 condensed exactly onto the node pairs (its compliance from one
sparse factorization), penalty springs per pair, Coulomb friction by return mapping, the
interference ramped from zero (the path a preload takes). The harmonic balance's order-0
forces at a vanishing excitation are that state; at 1 N the vibration already moves them
(shakedown of the pairs at their friction limit)."""

import copy
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from microslip.geometry.mesh import rotation_z
from microslip.pipeline import case as cases
from microslip.pipeline.app.run import run_case
from microslip.pipeline.fe import cyclic, fem

CASE = Path(__file__).parent.parent / "cases" / "shrouded_blisk.toml"


def _static_interlock(mesh, kn, kt, mu, interference, steps=200):
    """(N (p,), |T| (p,), slipping (p,)) of the pairs at the full interference."""
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
    C = B @ spla.splu(sector.stiffness.tocsc()).solve(B.T.toarray())  # g = -C lambda
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
    for d in np.linspace(0.0, interference, steps + 1)[1:]:
        for _ in range(60):  # Newton on g + C lambda(g) = 0, the law's tangent numerically
            lam, _ = law(g, s, d)
            J = np.eye(3 * p) + C @ np.column_stack(
                [(law(g + 1e-12 * e_j, s, d)[0] - lam) / 1e-12 for e_j in np.eye(3 * p)])
            step = np.linalg.solve(J, -(g + C @ lam))
            g += step
            if np.abs(step).max() < 1e-15:
                break
        lam, slip = law(g, s, d)
        lam = lam.reshape(p, 3)
        s = np.where(slip[:, None], g.reshape(p, 3)[:, :2] - lam[:, :2] / kt[:, None], s)
    return lam[:, 2], np.linalg.norm(lam[:, :2], axis=1), slip


@pytest.mark.slow
def test_the_interlocks_static_state_is_an_independent_static_solve(tmp_path):
    data = tomllib.loads(CASE.read_text())
    (frf,) = data["analysis"]
    frf.update(start=6600.0, stop=6620.0, maps=[], map_types=["status"],
               family={"key": "assembly.excitation", "values": [0.01, 1.0]})
    path = run_case(cases.Case(copy.deepcopy(data), "shroud.toml"), tmp_path,
                    progress=lambda _: None)
    with h5py.File(path) as f:
        kn = f["reduction/contact_stiffness/shroud/normal_n_per_m"][()].ravel()
        kt = f["reduction/contact_stiffness/shroud/tangential_n_per_m"][()].ravel()
        small, large = (f[f"frf/curve_00{i}/patches/shroud/static"][0] for i in (0, 1))
    mesh = cases.Case(data, "shroud.toml").geometry_table.build()
    contact = data["assembly"]["contacts"][0]
    N, T, slip = _static_interlock(mesh, kn, kt, contact["mu"], contact["interference"])
    # at 0.01 N (a vibration 2e-4 of the interference) the balance's static forces are the
    # static solve's: measured 3e-4 of the largest pair's normal load (the vibration's own
    # effect, which grows with it: 3 % at 1 N)
    scale = N.max()
    assert np.abs(small[:, 2] - N).max() < 2e-3 * scale
    assert np.abs(np.linalg.norm(small[:, :2], axis=1) - T).max() < 2e-3 * scale
    # every pair closed and at its friction limit: the interlock slid as the interference
    # grew (the 30 deg notch turns the preload into a sliding force above mu N)
    assert np.all(N > 0) and slip.all()
    assert np.abs(T - contact["mu"] * N).max() < 1e-9 * scale
    assert np.abs(large[:, 2] - N).max() > 1e-2 * scale  # (at 1 N: moved)
