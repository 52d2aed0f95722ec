"""The [assembly.mistuning] table of a case: the whole bladed disk, each blade's stiffness
deviating from the design (issue 43).

```toml
[assembly.mistuning]
body = "blisk"            # the cyclic body whose blades deviate (default: the only one), or
                          #   a body of separate blades (the root joint's "blade": each of
                          #   its N copies stiffer by its deviation, whole)
blade_radius = 0.205      # [m] a cyclic body's region: its elements whose centroid lies
                          #   farther from the axis, or
# region = "blisk/blade"  #   a node set: the body's elements whose corners all lie in it
deviation = [0.0, 0.02, -0.01, ...]  # the region's Young's modulus x (1 + d), per blade, or
# sigma = 0.02            #   drawn: d ~ normal(0, sigma), independent per blade,
# seed = 0                #   from a seeded generator (the same pattern on every machine)
```
(Neither: the tuned whole disk; a ``type = "mistuning"`` study draws its own patterns.)

With the table the case is the whole disk (``assembly.mistuned``): the sector's reductions
at every nodal diameter, each keeping the region's basis rows and stiffness, assembled into
the annulus with every sector's contacts, its loads at the engine order's phase and its
outputs per blade ("<output>#s", blade s at angle s 2 pi / N). All blades' deviations 0 is
the tuned whole disk, the cyclic sector's travelling wave on every blade.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .checks import is_int, is_number, unknown_keys

KEYS = {"body", "blade_radius", "region", "deviation", "sigma", "seed"}
#: the largest standard deviation drawn: 5 sigma stays above -100 % (a blade of no stiffness)
MAX_SIGMA = 0.2


@dataclass(frozen=True)
class MistuningTable:
    """A validated [assembly.mistuning] table (the module's keys)."""

    body: str | None = None
    blade_radius: float | None = None
    region: str | None = None
    deviation: tuple[float, ...] | None = None
    sigma: float | None = None
    seed: int = 0

    @classmethod
    def of(cls, table: Mapping[str, Any] | None) -> MistuningTable | None:
        """The spec of a validated table (None: no table, a cyclic case)."""
        if table is None:
            return None
        return cls(
            body=table.get("body"),
            blade_radius=None if "blade_radius" not in table else float(table["blade_radius"]),
            region=table.get("region"),
            deviation=None if "deviation" not in table else tuple(
                float(d) for d in table["deviation"]),
            sigma=None if "sigma" not in table else float(table["sigma"]),
            seed=int(table.get("seed", 0)))

    def body_of(self, cyclic_bodies: Sequence[str], bodies: Sequence[str] = ()) -> str:
        """The mistuned body: the table's (a cyclic body, which takes a region, or one of
        ``bodies`` copied per sector, which does not), else the mesh's only cyclic body."""
        if self.body is not None:
            copied = self.body not in cyclic_bodies
            if copied and self.body not in bodies:
                raise ValueError(f"assembly.mistuning.body = {self.body!r}: not a body; "
                                 f"bodies: {sorted({*cyclic_bodies, *bodies})}")
            if copied and (self.blade_radius is not None or self.region is not None):
                raise ValueError(f"assembly.mistuning.body = {self.body!r}: a body of "
                                 "separate blades deviates whole: blade_radius and region "
                                 "are a cyclic body's")
            if not copied and self.blade_radius is None and self.region is None:
                raise ValueError(f"assembly.mistuning.body = {self.body!r}: a cyclic body; "
                                 "give its blade: blade_radius (m) or region (a node set)")
            return self.body
        if len(cyclic_bodies) != 1:
            raise ValueError(f"assembly.mistuning.body: missing; the mesh has cyclic bodies "
                             f"{sorted(cyclic_bodies)}: name one")
        if self.blade_radius is None and self.region is None:
            raise ValueError("assembly.mistuning: give the blade of the cyclic body "
                             f"{next(iter(cyclic_bodies))!r}: blade_radius (m) or region (a "
                             "node set), or name a body of separate blades")
        return next(iter(cyclic_bodies))

    def deviations(self, sectors: int) -> tuple[float, ...]:
        """One deviation per blade (a fraction; none given: the tuned disk, all 0)."""
        if self.sigma is None and self.deviation is None:
            return (0.0,) * sectors
        if self.deviation is not None:
            if len(self.deviation) != sectors:
                raise ValueError(f"assembly.mistuning.deviation: {len(self.deviation)} values "
                                 f"for {sectors} blades: give one per blade")
            return self.deviation
        rng = np.random.default_rng(self.seed)
        return tuple(float(d) for d in self.sigma * rng.standard_normal(sectors))

    def elements(self, mesh: Any, body: str) -> np.ndarray:
        """(k,) sorted mesh elements of ``body`` in the region; ValueError if none."""
        index = np.sort(np.asarray(mesh.bodies[body], dtype=np.int64))
        cells = mesh.element_cells(index)  # shape -> corners, in index order
        if self.blade_radius is not None:
            centre = np.vstack([np.asarray(mesh.points)[c].mean(axis=1)
                                for c in cells.values()])
            inside = np.hypot(centre[:, 0], centre[:, 1]) > self.blade_radius
            what = f"blade_radius = {self.blade_radius:g} m"
        else:
            if self.region not in mesh.node_sets:
                raise ValueError(f"assembly.mistuning.region = {self.region!r}: not a node "
                                 "set of the mesh")
            nodes = np.asarray(mesh.node_sets[self.region], dtype=np.int64)
            inside = np.concatenate([np.isin(c, nodes).all(axis=1) for c in cells.values()])
            what = f"region = {self.region!r}"
        if not inside.any() or inside.all():
            raise ValueError(f"assembly.mistuning.{what}: holds {int(inside.sum())} of body "
                             f"{body!r}'s {len(index)} elements; the blade is a part of it")
        return index[inside]


def _cyclic_bodies(names: Mapping[str, Any] | None) -> tuple[str, ...]:
    """The cyclic bodies a geometry's names show (its "cyclic/<body>/left" sets), or ()."""
    if names is None:
        return ()
    return tuple(sorted({n.split("/")[1] for n in names.get("node_sets", ())
                         if n.startswith("cyclic/") and n.count("/") == 2}))


def check(table: Any, out: list[str], names: Mapping[str, Any] | None = None,
          sectors: int | None = None) -> None:
    """Append one line per fault of an [assembly.mistuning] table to ``out`` (``names``:
    the geometry's bodies and node sets, when known; ``sectors``: the blades, when known)."""
    pre = "assembly.mistuning"
    if not isinstance(table, dict):
        out.append(f"{pre}: expected a table, got {table!r}")
        return
    unknown_keys(f"{pre}.", table, KEYS, out)
    body = table.get("body")
    cyclic = _cyclic_bodies(names)
    if body is not None and not isinstance(body, str):
        out.append(f"{pre}.body = {body!r}: expected a body name")
    elif "blade_radius" in table and "region" in table:
        out.append(f"{pre}: give one of blade_radius (m) or region (a node set): the blade")
    elif cyclic:  # the geometry's cyclic bodies known: the run's own rule, before meshing
        given = MistuningTable(body=body, blade_radius=1.0 if "blade_radius" in table else None,
                               region="" if "region" in table else None)
        try:
            given.body_of(cyclic, tuple(names["bodies"]))
        except ValueError as err:
            out.append(str(err))
    elif body is not None and names is not None and body not in names["bodies"]:
        out.append(f"{pre}.body = {body!r}: not a body; bodies: {list(names['bodies'])}")
    elif "blade_radius" not in table and "region" not in table and body is None:
        out.append(f"{pre}: give the blade: blade_radius (m) or region (a node set) of the "
                   "cyclic body, or body = a body of separate blades")
    if "blade_radius" in table and not (is_number(table["blade_radius"])
                                        and table["blade_radius"] > 0):
        out.append(f"{pre}.blade_radius = {table['blade_radius']!r}: expected a radius > 0 [m]")
    region = table.get("region")
    if region is not None and not (isinstance(region, str) and (
            names is None or region in names["node_sets"])):
        out.append(f"{pre}.region = {region!r}: expected a node set of the geometry")
    if "deviation" in table and "sigma" in table:
        out.append(f"{pre}: give deviation (one fraction per blade) or sigma (drawn), not "
                   "both")
    dev = table.get("deviation")
    if dev is not None:
        if not (isinstance(dev, list) and dev and all(is_number(d) and d > -1 for d in dev)):
            out.append(f"{pre}.deviation = {dev!r}: expected a list of fractions > -1, one "
                       "per blade")
        elif sectors is not None and len(dev) != sectors:
            out.append(f"{pre}.deviation: {len(dev)} values for {sectors} blades: give one "
                       "per blade")
    sigma = table.get("sigma")
    if sigma is not None and not (is_number(sigma) and 0 <= sigma <= MAX_SIGMA):
        out.append(f"{pre}.sigma = {sigma!r}: expected a fraction in [0, {MAX_SIGMA}]")
    seed = table.get("seed")
    if seed is not None and not (is_int(seed) and seed >= 0):
        out.append(f"{pre}.seed = {seed!r}: expected an integer >= 0")
    if seed is not None and "sigma" not in table:
        out.append(f"{pre}.seed: only with sigma (a drawn pattern)")
