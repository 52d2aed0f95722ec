"""Benchmarks (``microslip bench ...``) and small demos.

core        FRF time per point, contact residual + Jacobian cost, harmonics/samples trade
meshing     nodes, elements and meshing time over a mesh-size sweep
reduction   assembly, cyclic matrices, Craig-Bampton per ND: time, memory, back-ends
teaching    harmonic balance against time integration on the 9-DOF model
demos       the single-DOF Jenkins oscillator
"""
