"""Case files: read, validated and built, every fault reported at once.

``file`` (``load``, ``check``), ``validated`` (the validated :class:`Case`), ``specs``
(the typed analysis specs and their defaults), ``validate`` (the faults of a table),
``checks`` (the helpers every table's validation uses), ``paths`` (dotted key paths),
``estimate`` (unknowns, memory and notes before anything is built), ``build`` (the lumped
model, harmonics, settings), ``geometry``, ``reduction`` and ``assembly`` (the tables of
meshed cases).
"""

from .build import (
    contact_elements,
    curve_variants,
    harmonics,
    lumped_model,
    operating_point,
    settings,
)
from .estimate import Size, notes, sizes, task_seconds
from .geometry_table import GeometryTable
from .loading import check, load
from .validated import Case, CaseError, InputError

__all__ = ["Case", "CaseError", "GeometryTable", "InputError", "Size", "check", "contact_elements",
           "curve_variants", "harmonics", "load", "lumped_model", "notes", "operating_point",
           "settings", "sizes", "task_seconds"]
