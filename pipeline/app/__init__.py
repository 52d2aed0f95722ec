"""The application layer: what a case file asks for, run end to end.

checks      validation helpers shared by the case and structural tables
case        case files (TOML): parse, validate, build the lumped model
coupled     the [coupling] table: bodies joined at contact patches
structure   the structural stage: mesh -> reduced models per body and ND, patch stiffness
models      the lumped or coupled models of a case, built once
run         every analysis of a case into results.h5, then its pictures (``draw``)
solutions   the map points of an FRF: refined peak, every solution at a value
limits      the free and fully stuck linear limits
store       curves kept between runs, picture stamps
plan        ``run --dry-run``: the stages, cached or not, with rough time and memory
progress    time left
"""
