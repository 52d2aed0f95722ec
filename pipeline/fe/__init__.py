"""Linear finite elements: from a mesh to reduced models of each body.

fem                 K, M of a body (scikit-fem), clamps, damping, centrifugal load
basis               the scikit-fem elements and quadrature of each solid shape
cyclic              complex K_h, M_h of a sector per nodal diameter (Firrone & Zucca 5.1.1)
reduced_model       the reduced model of a body and ND: record, HDF5 file, content key
craig_bampton       Craig-Bampton reduction (masters, static and fixed-interface modes)
modal               modal superposition, the alternative reduction
bodies              what to reduce per body (BodySpec) and the cached reduction stage
body_modes          a body's modes unreduced against its reduced model's
contact_stiffness   flat-punch stiffness of a contact patch, local contact frames
linalg              sparse factorizations (SuperLU, MKL PARDISO), sparse products
eigen               the lowest modes of a pencil: dense, ARPACK, block shift-invert Krylov
"""
