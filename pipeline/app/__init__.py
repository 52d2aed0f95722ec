"""The application layer: what a case file asks for, run end to end.

structure   the structural stage: mesh -> reduced models per body and ND, patch stiffness
models      the lumped or assembly models of a case, built once
run         every analysis of a case into results.h5, then its pictures (``draw``)
solutions   the map points of an FRF: refined peak, every solution at a value
limits      the free and fully stuck linear limits
store       curves kept between runs, picture stamps
plan        ``run --dry-run``: the stages, cached or not, with rough time and memory
progress    time left
"""
