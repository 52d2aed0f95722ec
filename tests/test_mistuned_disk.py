"""The whole blisk with its wedge dampers built from the sector's reductions at every nodal
diameter (assembly/mistuned), in the harmonic balance with every sector's contacts: tuned,
it is the cyclic sector's solution on every sector (the friction too); the names and the
engine order's phases of the full disk's spec."""

import numpy as np
import pytest

from microslip import geometry
from microslip.app import structure
from microslip.assembly.join import join
from microslip.assembly.mistuned import annulus_bodies, annulus_spec
from microslip.assembly.spec import AssemblySpec, NodalLoad, Output, PatchFriction
from microslip.fourier import Harmonics
from microslip.solve.continuation import Settings
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point

NS = 6
SPEED = 1000.0  # rad/s: the dampers' centrifugal load closes the contacts
# the coarse sector of test_assembly (3 x 2 pairs per flank, linear tetrahedra)
GEOMETRY = dict(sectors=NS, size=0.03, blade_size=0.012, contact_n_axial=3, contact_n_flank=2)
REDUCTION = {"modes": "auto", "f_max": 1500.0, "order": 1,
             "damping": {"modal_ratios": 0.005}, "nodal_diameters": [0, 1, 2, 3]}


@pytest.fixture(scope="module")
def sector():
    mesh = geometry.blisk_sector(**GEOMETRY)
    return mesh, structure.reduce_structure(mesh, REDUCTION, None, progress=lambda s: None)


@pytest.fixture(scope="module")
def whole(sector):
    """The full disk's mesh (names) and its bodies from the sector's reductions."""
    mesh, red = sector
    return geometry.full_disk(mesh), annulus_bodies(mesh, red.models)


def spec(mu: float, eo: int, amplitude: float) -> AssemblySpec:
    return AssemblySpec(
        contacts=tuple(PatchFriction(p, mu) for p in ("damper_left", "damper_right")),
        engine_order=eo, loads=(NodalLoad("blisk/excitation", "tangential", amplitude),),
        outputs=(Output("tip", "blisk/response", "tangential"),), speed=SPEED,
        centrifugal=("damper",), mass_bodies=("damper",))


def first_bending(sector) -> float:
    return 2 * np.pi * sector[1].frequencies["blisk", 1][0]


#: Newton to 1e-12 of the force scale (1e-9 by default): the two models' solutions then
#: agree to ~1e-9 of the response, what "the same solution" can be held to
TIGHT = Settings(tol=1e-12)


def solved(cm, w):
    p = OperatingPoint(w)
    r = solve_point(cm.hb, p, settings=TIGHT)
    assert r.converged, r.reason
    return cm.output_coefficients(r.x, p)


def test_the_full_disks_spec_puts_the_sectors_contacts_loads_and_outputs_on_every_sector():
    s = annulus_spec(spec(0.5, 2, 3.0), NS, ("blisk",))
    assert [c.patch for c in s.contacts][:3] == ["damper_left#0", "damper_right#0",
                                                 "damper_left#1"]
    assert len(s.contacts) == 2 * NS and len(s.outputs) == NS
    assert s.outputs[4] == Output("tip#4", "blisk/response#4", "tangential")
    # sector s: the phase harmonic EO s phi
    np.testing.assert_allclose([x.phase for x in s.loads], 2 * np.arange(NS) * 2 * np.pi / NS)
    assert s.centrifugal == tuple(f"damper#{k}" for k in range(NS))


@pytest.mark.parametrize("eo", [5, pytest.param(1, marks=pytest.mark.slow)])  # ND 1
# backward (conjugated matrices), and forward
@pytest.mark.parametrize("mu, amplitude, tol", [
    # stuck: the same linear system seen through the same bases, measured 1e-12
    (1e4, 1.0, 1e-8),
    # microslip: 3e-5 to 6e-5 measured at the peak, the sectors' static tip offsets up to 7 %
    # apart. Why: a contact's mean force in partial slip depends on where in the period the
    # law's march starts (the same periodic motion shifted by a sixth of a period moves a
    # damper's mean contact forces by 6 %, measured), and sector s of the whole disk starts
    # its march EO s phi later in its own cycle than the sector model does: the travelling
    # wave is not an exact solution of the sampled whole disk (issue 43's notes)
    pytest.param(0.5, 15.0, 1e-4, marks=pytest.mark.slow)])
def test_the_tuned_whole_disk_is_the_cyclic_sector_on_every_blade(sector, whole, eo, mu,
                                                                    amplitude, tol):
    """Every blade's tip (static and first harmonic) against the cyclic sector's at three
    frequencies through the resonance: the same reductions, the same contacts on every
    sector, so the sector's travelling wave solves the whole disk (Newton to 1e-12 of the
    force scale). Each blade's phase is the engine order's."""
    mesh, red = sector
    full, bodies = whole
    stiffness = {f"{p}#{s}": ps for p, ps in red.patch_stiffness.items() for s in range(NS)}
    h = Harmonics.up_to(1, 64)
    cyc = join(mesh, red.models, red.patch_stiffness, spec(mu, eo, amplitude), h)
    disk = join(full, bodies, stiffness, annulus_spec(spec(mu, eo, amplitude), NS,
                                                      ("blisk",)), h)
    assert disk.hb.n_unknowns > NS * cyc.hb.n_unknowns * 0.9  # every sector's contacts
    phi = 2 * np.pi / NS
    for w in first_bending(sector) * np.array([0.98, 1.0, 1.02]):
        a = solved(cyc, w)[0]  # [X0, cos, sin] of the tip
        out = solved(disk, w)
        for s in range(NS):
            b = out[s]
            # cos(w t + theta) has (cos theta, -sin theta): sector s's phase EO s phi turns
            # complex(cos, sin) by -EO s phi
            want = np.exp(-1j * eo * s * phi) * complex(a[1], a[2])
            assert abs(complex(b[1], b[2]) - want) <= tol * abs(want), (w, s)
            assert abs(b[0] - a[0]) <= tol * abs(want), (w, s)
