"""Coupling: reduced bodies + contact patches -> the model the harmonic balance solves.

spec       what couples the bodies: contacts per patch, loads, speed, outputs (dataclasses)
join       ``couple``: per-order linear blocks, contact kinematics (neighbour-sector phase
           and rotation), nodal and centrifugal loads
recovery   the assembly model and its recovery to bodies, patches, nodes and outputs
annulus    the whole annulus from a sector's reductions at every nodal diameter, tuned or
           mistuned blade by blade (real coordinates)
mistuned   the whole disk as the full disk's reduced bodies and spec, for ``join``
"""
