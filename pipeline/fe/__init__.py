"""Linear finite elements: from a mesh to reduced models of each body.

fem                 K, M of a body (scikit-fem, P2/P1 tetrahedra), clamps, damping
cyclic              complex K_h, M_h of a sector per nodal diameter (Firrone & Zucca 5.1.1)
reduction           Craig-Bampton / modal reduction per body and ND, HDF5 cache
contact_stiffness   flat-punch stiffness of a contact patch, local contact frames
linalg              sparse factorizations (SuperLU, MKL PARDISO), block Lanczos
"""
