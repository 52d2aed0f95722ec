"""Nonlinear solution of a model with friction contacts.

hbm            the multi-harmonic balance on the contact DOFs (linear part condensed)
continuation   Newton, natural and pseudo-arclength continuation in any scalar parameter
response       frequency responses, peak curves and their post-processing
dti            direct time integration of the same lumped model (the reference)
"""
