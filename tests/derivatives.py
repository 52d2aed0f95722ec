"""Central differences shared by the derivative tests (independent of the analytic ones)."""

import numpy as np


def fd_contact_jacobian(el, g, h, eps):
    """(P, c nc, c nc) central differences of a contact set's forces over every input
    coefficient of g (P, c, nc)."""
    P = el.size
    flat = g.reshape(P, -1)
    J = np.empty((P, flat.shape[1], flat.shape[1]))
    for i in range(flat.shape[1]):
        gp, gm = flat.copy(), flat.copy()
        gp[:, i] += eps
        gm[:, i] -= eps
        fp = el.evaluate(gp.reshape(g.shape), h, jacobian=False).forces.reshape(P, -1)
        fm = el.evaluate(gm.reshape(g.shape), h, jacobian=False).forces.reshape(P, -1)
        J[:, :, i] = (fp - fm) / (2 * eps)
    return J


def fd_residual_jacobian(hb, x, point, eps):
    """(n, n) central differences of a harmonic-balance residual over every unknown."""
    J = np.empty((x.size, x.size))
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = eps
        J[:, i] = (hb.residual(x + e, point, jacobian=False)[0]
                   - hb.residual(x - e, point, jacobian=False)[0]) / (2 * eps)
    return J
