"""Small models shared by the tests (built through the public API only)."""

import numpy as np

from microslip.bench.demos import jenkins_oscillator  # noqa: F401  (re-exported for the tests)
from microslip.fourier import Harmonics
from microslip.laws.coulomb import ContactElements
from microslip.solve.hbm import Contact, HarmonicBalance
from microslip.solve.linear import Excitation, LinearDynamics


def normal_oscillator(n0, H=5, ns=256, *, kn=3.0, kt=3.0, mu=0.3, P=0.1, c=0.02):
    """Single DOF moving normal to a wall and tangentially along it (law B):
    the mass's motion is 45 deg to the wall, so u = v = x / sqrt(2)."""
    h = Harmonics.up_to(H, ns)
    lin = LinearDynamics.create([[1.0]], [[1.0]], [[c]], harmonics=h)
    el = ContactElements.create("B", kt=kt, kn=kn, mu=mu, n0=n0)
    B = np.array([[1.0], [1.0]]) / np.sqrt(2)
    return HarmonicBalance(lin, [Contact("wall", el, B)], Excitation.single(1, 0, P), h)


def three_dof_cyclic_like(h, coupled=True):
    """Three DOFs with complex Hermitian matrices per harmonic (as a cyclic
    sector would give), complex kinematics, a DOF that no contact touches (so
    it is condensed), laws D and B together and a static load."""
    rng = np.random.default_rng(11)
    K, M, C, B = {}, {}, {}, {}
    for o in h.orders:
        A = rng.normal(size=(3, 3)) + (1j * rng.normal(size=(3, 3)) if o else 0)
        K[o] = 3 * np.eye(3) + 0.3 * (A + A.conj().T)
        M[o] = np.eye(3) + 0.05 * np.real(A + A.T)
        C[o] = 0.02 * K[o]
        ph = np.exp(1j * 0.7 * o) if o else 1.0
        B[o] = np.array([[1.0, -0.3 * ph, 0.0], [0.2, 1.0 * ph, 0.0], [0.5, 0.0, 0.0]])
    lin = LinearDynamics.create(K, M, C, harmonics=h, mass_part=np.diag([0.0, 0.5, 0.0]))
    kw = dict(interference=0.05) if coupled else dict(n0=0.1)
    d = ContactElements.create("D", kt=2.0, kn=4.0, mu=0.3, coupled=coupled, **kw)
    b = ContactElements.create("B", kt=1.0, kn=3.0, mu=0.4, coupled=coupled, **kw)
    Bb = {o: np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]) for o in h.orders}
    forces = {0: np.array([0.0, 0.0, -0.1]), 1: np.array([0.0, 0.0, 0.3 + 0.1j])}
    return HarmonicBalance(lin, [Contact("d", d, B), Contact("b", b, Bb)],
                           Excitation(forces), h)


def friction_grid(n_points: int, H: int = 1, ns: int = 64, *, cyclic: bool = True,
                  shared: bool = False, dampers: bool = False):
    """A sector-like model with ``n_points`` law-D contacts (2D friction, variable normal
    load), each between two nodes of 3 DOFs (6 n_points shared DOFs, plus 4 no contact
    touches, condensed): complex Hermitian stiffness per order (a nodal diameter's),
    complex kinematics on one side (the neighbour sector's phase), proportional damping, a
    static normal preload and a tangential excitation. ``shared``: neighbouring points
    share a node (their blocks overlap, as on a patch whose grid reuses nodes). ``dampers``:
    each point's second node a body of its own (as a disk's dampers are), the first nodes
    and the 4 others one body."""
    h = Harmonics.up_to(H, ns)
    rng = np.random.default_rng(n_points)
    nodes = n_points + 1 if shared else 2 * n_points
    n = 3 * nodes + 4
    A = rng.normal(size=(n, n)) / np.sqrt(n)
    base = 4.0 * np.eye(n) + 0.5 * (A + A.T) + np.diag(np.arange(n) / n)
    body = np.zeros(n, dtype=int)  # (the first nodes and the 4 others: body 0)
    if dampers:
        body[:3 * nodes] = np.where(np.arange(3 * nodes) // 3 % 2, np.arange(3 * nodes) // 6 + 1, 0)
    apart = body[:, None] != body[None, :]
    K, M, C = {}, {}, {}
    for o in h.orders:
        E = rng.normal(size=(n, n)) / np.sqrt(n)
        K[o] = np.where(apart, 0.0, base + (0.2j * (E - E.T) if o else 0.0))
        M[o] = np.eye(n)
        C[o] = np.where(apart, 0.0, 0.01 * base)
    B = {}
    for o in h.orders:
        ph = np.exp(0.4j * o) if (cyclic and o) else 1.0
        Bo = np.zeros((3 * n_points, n), dtype=complex)
        for p in range(n_points):
            a, b = (p, p + 1) if shared else (2 * p, 2 * p + 1)
            Bo[3 * p:3 * p + 3, 3 * a:3 * a + 3] = np.eye(3)
            Bo[3 * p:3 * p + 3, 3 * b:3 * b + 3] = -ph * np.eye(3)
        B[o] = Bo if cyclic else Bo.real
    el = ContactElements.create("D", kt=3.0, kn=5.0, mu=0.3, n0=np.linspace(0.5, 1.5, n_points),
                                n_points=n_points)
    f1 = np.zeros(n, dtype=complex)
    f1[0::3][: nodes] = 0.4 * np.exp(0.3j * np.arange(nodes))
    forces = {o: (f1 if o == 1 else np.zeros(n)) for o in h.orders}
    return HarmonicBalance(LinearDynamics.create(K, M, C, harmonics=h), [Contact("grid", el, B)],
                           Excitation(forces), h)
