"""The application layer: what a case file asks for, run end to end.

run          every analysis of a case into results.h5, each by its kind, then its pictures
analyses     the analysis types, a module each: checks, estimate, runner, tasks, pictures
running      what the analyses share: the Run, the one loop of tasks, cached curves
stages       the stages before the analyses: the mesh and the reduced models, written
structure    the structural stage: mesh -> reduced models per body and ND, patch stiffness
models       the lumped or assembly models of a case, built once
solutions    the map points of an FRF: refined peak, every solution at a value
limits       the free and fully stuck linear limits
tasks        independent curves as tasks: in this process, or on a Dask cluster
worker       what a Dask worker holds: the case's models, pushed once
store        curves kept between runs, picture stamps
cache        the shared cache of meshes and reduced models
folder       the output folder: one run at a time, room to save what finished
plan         ``run --dry-run``: the stages, cached or not, with rough time and memory
progress     time left
"""
