"""The application layer: what a case file asks for, run end to end.

checks      validation helpers shared by the case and structural tables
case        case files (TOML): parse, validate, build the lumped model
structure   the structural stage: mesh -> reduced models per body and ND, patch stiffness
run         every analysis of a case; results.h5 and pictures
results     the HDF5 results file (atomic, partial on interrupt) and its summary
plots       FRFs, peak curves, loops, time histories (matplotlib, off screen)
"""
