"""Contact-status and static-load maps: every node's cell carries its own state's colour, the
map is oriented by the radius, and a real off-screen render gives a PNG of the asked size."""

from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb

from microslip.draw import maps
from microslip.laws.coulomb import slip_share
from microslip.laws.states import GROSS_SLIP, OPEN, PARTIAL_LIFTOFF, STICK, STICK_SLIP


def flank(n1: int = 5, n2: int = 3) -> maps.PatchGrid:
    """A 45 deg flank at radius ~0.2 m: a skewed, unevenly spaced n1 x n2 grid (the tributary
    cells must still hold their own node)."""
    s = np.cumsum(np.r_[0.0, 1.0 + 0.3 * np.arange(n1 - 1)]) * 1e-3  # uneven along i
    t = np.linspace(0.0, 4e-3, n2)
    centre = np.array([0.0, 0.2, 0.0])
    along = np.array([0.0, 0.0, 1.0])  # axial
    up = np.array([0.5, 0.5, 0.0]) * np.sqrt(2)  # in the plane, with a radial component
    points = centre + s[:, None, None] * along + t[None, :, None] * up
    n = np.cross(along, up)
    frame = np.stack([along, np.cross(n, along), n])
    return maps.PatchGrid("flank", "damper", "blisk", points, frame,
                          maps.map_axes(points, frame), maps.high_radius_edge(points),
                          np.arange(n1 * n2).reshape(n1, n2),
                          np.arange(n1 * n2).reshape(n1, n2) + 100)


def test_each_node_sits_in_its_own_cell_with_its_own_states_colour():
    import pyvista as pv  # noqa: F401 (the cells are a pyvista grid)

    grid = flank()
    states = np.array([STICK, STICK_SLIP, GROSS_SLIP, PARTIAL_LIFTOFF, OPEN] * 3)
    sg = maps.cells(grid, maps.state_rgb(states), "rgb")
    assert sg.n_cells == states.size
    plane = 1e3 * grid.plane.reshape(-1, 2)  # the cells are in mm
    for k, (x, y) in enumerate(plane):
        cell = sg.find_containing_cell([x, y, 0.0])
        assert cell >= 0
        expected = np.round(255 * np.array(to_rgb(maps.STATE_COLOURS[states[k]])))
        np.testing.assert_array_equal(sg.cell_data["rgb"][cell], expected)


def test_the_cells_tile_the_patch_without_overlap():
    # the tributary areas add up to the patch's outline area: halfway between the nodes,
    # half a spacing beyond the outer ones
    grid = flank(4, 4)
    c = maps.cell_corners(grid.plane)
    area = 0.0
    for i in range(c.shape[0] - 1):
        for j in range(c.shape[1] - 1):
            q = np.array([c[i, j], c[i + 1, j], c[i + 1, j + 1], c[i, j + 1]])
            d1, d2 = q[2] - q[0], q[3] - q[1]
            area += 0.5 * abs(d1[0] * d2[1] - d1[1] * d2[0])
    s = np.cumsum(np.r_[0.0, 1.0 + 0.3 * np.arange(3)]) * 1e-3
    width = s[-1] + 0.5 * (s[1] - s[0]) + 0.5 * (s[-1] - s[-2])
    height = 4e-3 * (1 + 1 / 3)  # 3 spacings of 4/3 mm, plus half of one at each end
    assert area == pytest.approx(width * height, rel=1e-12)


def test_the_map_looks_along_the_normal_with_the_radius_up():
    grid = flank()
    right, up = grid.axes
    assert np.cross(right, up) == pytest.approx(grid.frame[2])
    # up: towards growing radius; the high-radius edge is the last column (t grows radially)
    centre = grid.points.reshape(-1, 3).mean(axis=0)
    assert np.hypot(*(centre + 1e-3 * up)[:2]) > np.hypot(*centre[:2])
    assert maps.EDGES[grid.high_edge].startswith("last column")
    r = np.hypot(grid.points[..., 0], grid.points[..., 1])
    assert grid.plane[..., 1].ravel() @ (r.ravel() - r.mean()) > 0  # up on the map = radius


def test_the_slip_share_counts_stick_slip_and_gross_slip_only():
    states = np.array([STICK, STICK_SLIP, GROSS_SLIP, PARTIAL_LIFTOFF, OPEN, STICK_SLIP])
    assert slip_share(states) == pytest.approx(3 / 6)
    assert slip_share(np.zeros(0, dtype=int)) == 0.0


def test_an_off_screen_status_map_is_a_png_of_the_asked_size(tmp_path):
    from PIL import Image

    grid = flank()
    states = np.full(15, STICK)
    states[7] = OPEN  # the middle node
    states[[0, 1]] = PARTIAL_LIFTOFF
    panel = (300, 240)
    path = maps.status_maps(tmp_path / "status.png", "one map",
                            [[maps.Panel(grid, states, "test")]], panel=panel)
    image = np.asarray(Image.open(path).convert("RGB"))
    from microslip.draw import text

    # one column is drawn two panels wide (its title and the legend need the room); the
    # title's strip as tall as its line, the legend's as its rows (two at 600 px wide)
    strip = text.measure("one map", text.TITLE)[1] + 2 * text.GAP
    rows = len(maps.legend_rows(["stick", "stick-slip", "gross slip", "partial lift-off",
                                 "open"], 2 * panel[0]))
    assert rows == 2
    assert image.shape == (panel[1] + strip + rows * maps.LEGEND_ROW + 2 * text.GAP,
                           2 * panel[0], 3)
    assert image.std() > 10  # not blank
    open_rgb = np.round(255 * np.array(to_rgb(maps.STATE_COLOURS[OPEN])))
    hits = np.all(np.abs(image[strip: strip + panel[1]] - open_rgb) < 3, axis=-1)
    assert hits.sum() > 50  # the open node's cell is drawn in the map itself



def test_the_slip_at_each_peak_is_the_share_of_slipping_pairs_against_the_family(tmp_path):
    import h5py

    from microslip.draw import pictures

    states = {1.0: ([STICK] * 5 + [STICK_SLIP], [STICK] * 6),
              3.0: ([STICK_SLIP] * 3 + [STICK] * 3, [GROSS_SLIP, PARTIAL_LIFTOFF] + [STICK] * 4)}
    with h5py.File(tmp_path / "r.h5", "w") as f:
        g = f.create_group("frf")
        # the analysis' record (specs.Analysis.record): what the drawers read
        g.attrs.update({"type": "frf", "name": "frf", "start": 1.0, "stop": 2.0})
        g.attrs["family"] = ('{"key": "assembly.excitation", "label": "excitation [N]", '
                             '"values": [1.0, 3.0]}')
        for j, (value, (left, right)) in enumerate(states.items()):
            c = g.create_group(f"curve_{j:03d}")
            c.attrs["family_value"] = value
            p = c.create_group("maps/point_00")
            p.attrs["what"] = "peak"
            p.create_dataset("patches/left/state", data=np.array(left, dtype=np.int8))
            p.create_dataset("patches/right/state", data=np.array(right, dtype=np.int8))
        x, shares = pictures.slip_at_peaks(g)
        np.testing.assert_array_equal(x, [1.0, 3.0])
        np.testing.assert_allclose(shares["left"], [100 / 6, 50.0])
        np.testing.assert_allclose(shares["right"], [0.0, 100 / 6])  # lift-off is not slip
        np.testing.assert_allclose(shares["all patches"], [100 / 12, 400 / 12])
        np.testing.assert_allclose(shares["all patches, not stuck (slip or lift-off)"],
                                   [100 / 12, 500 / 12])
        assert pictures.slip_growth(g, "frf", tmp_path) == [tmp_path / "frf_slip.png"]
    assert (tmp_path / "frf_slip.png").stat().st_size > 10_000


def test_the_refined_peaks_are_the_maximum_of_a_fine_grid_of_direct_solves():
    # the Jenkins oscillator's FRF: the maps' peak (to 1e-4 of the bracket) and Response.peak
    # (to 1e-9), both by refine_peak, against an independent reference: the largest of
    # 801 direct Newton solves spread over the bracket of the computed maximum
    from microslip.app.solutions import map_solutions
    from microslip.bench.demos import jenkins_oscillator
    from microslip.solve.continuation import Settings
    from microslip.solve.linear import OperatingPoint
    from microslip.solve.response import solve_point, sweep

    hb = jenkins_oscillator(3, 128)
    r = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5), settings=Settings(max_step=0.2))
    (what, w, x), = map_solutions(r, ["peak"], [0], "peak", Settings(tol=1e-11))
    w_fine, a_fine = r.peak(0)
    a = hb.harmonics.peak(hb.recover(x, OperatingPoint(w))[0])
    amp = r.amplitude([0])[:, 0]
    i = int(np.argmax(amp))
    grid = np.linspace(r.values[i - 1], r.values[i + 1], 801)
    x0, tops = r.branch.x[i], []
    for g in grid:
        sol = solve_point(hb, OperatingPoint(g), settings=Settings(tol=1e-11), x0=x0)
        x0 = sol.x
        tops.append(hb.harmonics.peak(hb.recover(sol.x, OperatingPoint(g))[0]))
    k = int(np.argmax(tops))
    assert what == "peak"
    # the top is a kink (a stick-slip transition of the sampled period): there the amplitude
    # changes linearly, ~1.4 per rad/s. Grid spacing 3.3e-6 rad/s: the grid's top is within
    # ~5e-6 of the amplitude (relative), so 1e-5; the maps stop at 1e-4 of the bracket:
    # ~4e-7 more; the finer search never below the grid (it is a maximum search)
    assert a_fine == pytest.approx(tops[k], rel=1e-5) and a_fine >= tops[k] - 1e-12
    assert a == pytest.approx(tops[k], rel=1e-5)
    assert w_fine == pytest.approx(grid[k], abs=2 * (grid[1] - grid[0]))
    assert w == pytest.approx(grid[k], rel=1e-4)
    assert a >= np.max(amp) - 1e-15  # never below the computed points


@pytest.mark.parametrize("share", [0.5, 0.99])
def test_every_solution_in_a_fold_is_found_from_a_coarse_branch(share):
    # Firrone & Zucca Fig. 24 (the hardening curve of cases/03_normal_load.toml): a fine
    # arclength branch thinned to every 20th point before its first turning point and after
    # its second, and the two turning points (the middle branch one chord between them, the
    # secant guess far off the branch: it finds 2 of the 3 solutions); at a frequency at
    # `share` of the fold from its lower turn (0.99: the lower and middle solutions 1 % of
    # the fold apart),
    # the three solutions match those solved from the fine branch's own short brackets
    import dataclasses

    from microslip import case as cases
    from microslip.app.solutions import map_solutions, response_at
    from microslip.solve.continuation import Settings
    from microslip.solve.response import solve_point, sweep

    case = cases.load(Path(__file__).parents[1] / "cases" / "03_normal_load.toml")
    hb = cases.lumped_model(case.with_value("contacts.wall.n0", -0.5))
    base = cases.operating_point(omega=0.9)
    fine = sweep(hb, "frequency", 0.9, 1.6, base, settings=Settings(max_step=0.005))
    lam, xs = fine.values, fine.branch.x
    turn = [i for i in range(1, len(lam) - 1) if (lam[i] - lam[i - 1]) * (lam[i + 1] - lam[i]) < 0]
    assert len(turn) == 2  # the fold's two turning points
    keep = [*range(turn[0] % 20, turn[0] + 1, 20), *range(turn[1], len(lam), 20)]
    coarse = dataclasses.replace(fine, branch=dataclasses.replace(
        fine.branch, values=lam[keep], x=xs[keep], residuals=fine.branch.residuals[keep],
        iterations=fine.branch.iterations[keep], turning_points=[]))
    w = lam[turn[1]] + share * (lam[turn[0]] - lam[turn[1]])
    found = map_solutions(coarse, [w], [0], "peak", Settings(tol=1e-11))
    assert [what for what, _, _ in found] == [
        f"frequency = {w:.7g}, solution {k} of 3" for k in (1, 2, 3)]
    at = base.set("frequency", w)
    amplitude = [response_at(hb, x, at, [0], "peak")[0] for _, _, x in found]
    reference = []
    for j in np.flatnonzero((lam[:-1] - w) * (lam[1:] - w) <= 0):
        t = (w - lam[j]) / (lam[j + 1] - lam[j])
        r = solve_point(hb, at, settings=Settings(tol=1e-11), x0=xs[j] + t * (xs[j + 1] - xs[j]))
        reference.append(response_at(hb, r.x, at, [0], "peak")[0])
    # both solved to a residual of 1e-11 of the force scale: the amplitudes agree to ~1e-9
    np.testing.assert_allclose(amplitude, sorted(reference, reverse=True), rtol=1e-8)


def test_a_peak_trial_starts_between_its_neighbours():
    """The refined peak's trial start: linear between the nearest solutions either side,
    the nearest one beyond them (an extrapolation could leave the branch)."""
    from microslip.solve.response import between

    tried = {1.0: np.array([0.0, 2.0]), 3.0: np.array([4.0, 6.0]), 2.0: np.array([1.0, 1.0])}
    assert np.allclose(between(tried, 2.5), [2.5, 3.5])  # between 2 and 3: halfway
    assert np.allclose(between(tried, 1.25), [0.25, 1.75])  # a quarter from 1 to 2
    assert np.array_equal(between(tried, 2.0), [1.0, 1.0])  # a tried value: itself
    assert np.array_equal(between(tried, 0.5), [0.0, 2.0])  # below every one: the nearest
    assert np.array_equal(between(tried, 9.0), [4.0, 6.0])
