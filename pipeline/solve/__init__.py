"""Nonlinear solution of a model with friction contacts.

hbm            the multi-harmonic balance on the contact DOFs (linear part condensed)
linear         its linear part per order, the external forces, the operating point
condensation   the linear part condensed on the contact DOFs, per harmonic order
modal_condensation  the same through each body's modes, where its damping is modal
component_condensation  the same body by body, the large bodies lazily (the whole disk's)
blocks         block-diagonal matrices held as their bodies' blocks
jacobian       the balance's Jacobian as a structured operator and its solves
memory         the memory a balance will hold, from its sizes alone
newton         Newton's method at a fixed parameter and on the bordered system
continuation   natural continuation and the sweep driver in any scalar parameter
arclength      pseudo-arclength continuation: predictor, corrector, step control
branch         a continuation's results: the points of a branch
response       frequency responses, the response measures, solve_point, the hints
peaks          peak curves: the peak over a window tracked against a parameter
nonlinear_modes  nonlinear modes (extended periodic motion concept): w(a), zeta(a)
modal_synthesis  the forced response and its peaks synthesized from a nonlinear mode
stability      Hill's stability of a periodic solution
bifurcation    bifurcations along a branch, detected and located
sampling       uncertainty studies: the design of the samples, their statistics
dti            direct time integration of the same lumped model (the reference)
"""
