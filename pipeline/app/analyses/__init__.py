"""The analysis types, a module each: its checks, estimate, dry-run stages, runner and
tasks, and the drawer of its pictures, gathered in its ``KIND`` (``case.kinds``).

frf                  response curves in a parameter, maps and linear limits
peak                 the peak over a window against a parameter
uncertainty          the spread of a peak over sampled uncertain parameters
mistuning            the worst blade's amplification over random mistuning patterns
loops                hysteresis loops of a law under a prescribed motion
direct_integration   steady responses by time integration (``type = "dti"``)
transient            the two load steps as time histories
modes                the reduced bodies' modes against the unreduced ones
nonlinear_modes      a nonlinear mode's frequency and damping against the level, peaks from it

A new type is a new module here with its ``KIND``: :data:`KINDS` gathers every module's, so
nothing else is edited to add one (its results names go in ``results.schema``, its keys in
the README's Analyses table).
"""

from __future__ import annotations

import importlib
import pkgutil

from microslip.case.kinds import Kinds


def _gathered() -> Kinds:
    """The ``KIND`` of every module of this package, in the order of the map above (a
    module the map does not name, after them by name)."""
    order = [line.split()[0] for line in (__doc__ or "").splitlines() if line[:1].isalpha()
             and "  " in line]
    names = sorted((m.name for m in pkgutil.iter_modules(__path__)),
                   key=lambda n: (order.index(n) if n in order else len(order), n))
    return Kinds(tuple(importlib.import_module(f"{__name__}.{n}").KIND for n in names))


#: Every shipped analysis type, by its ``type`` key.
KINDS = _gathered()
