"""Benchmarks (``microslip bench ...``) and small demos.

core        FRF time per point, contact residual + Jacobian cost, harmonics/samples trade
meshing     nodes, elements and meshing time over a mesh-size sweep
reduction   assembly, cyclic matrices, Craig-Bampton per ND: time, memory, back-ends
teaching    harmonic balance against time integration on the 9-DOF model
coupled     the coupled harmonic balance at full scale: time per point against grid and H
trade       speed against accuracy at full scale: grid, harmonics, modes, mesh (table + PNG)
convergence mesh convergence of a full-scale case's linear limits (Richardson), then its grid
elements    element shapes and orders against a converged cantilever: error, DOFs, time
demos       the single-DOF Jenkins oscillator
"""
