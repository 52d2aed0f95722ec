"""Benchmarks (``microslip bench ...``) and small demos, a module per bench.

core            FRF time per point, contact residual + Jacobian cost, harmonics/samples trade
meshing         nodes, elements and meshing time over a mesh-size sweep
reduction_cost  assembly, cyclic matrices, Craig-Bampton per ND: time, memory, back-ends
teaching        harmonic balance against time integration on the 9-DOF model
assembly_scale  the coupled harmonic balance at full scale: time per point against grid and H
trade           speed against accuracy at full scale: grid, harmonics, modes, mesh (table + PNG)
convergence     mesh convergence of a full-scale case's linear limits (Richardson), its grid
element_orders  element shapes and orders against a converged cantilever: error, DOFs, time
cluster         what a Dask cluster buys: overhead per task, studies' speed-up
solvers         every shipped case by dense LUs and by the structured Jacobian, compared
demos           the single-DOF Jenkins oscillator
"""
