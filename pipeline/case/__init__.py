"""Case files: read, validated and built, every fault reported at once.

loading          ``load`` and ``check`` of a case file (TOML), renamed tables
validated        the validated :class:`Case` and copies with keys overridden
specs            what every analysis spec has, the case tables' specs, their defaults
kinds            the analysis types: the interface each one keeps, and the registry
faults           the faults of a case table, one line each
analysis_rules   the rules several analysis types share (their checks call them)
checks           the helpers every table's validation uses
paths            dotted key paths into a case table
estimate         unknowns, memory and notes before anything is built
build            the lumped model, harmonics, settings, operating points, variants
units            whether an imported model is plausible in its units
geometry_table   the [geometry] table: a parametric model or an imported mesh
reduction_table  the [reduction] table: bodies, masters, supports, mode selection
assembly_table   the [assembly] table: contacts per patch, loads, outputs
mistuning_table  the [assembly.mistuning] table: the whole disk, each blade's deviation
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
