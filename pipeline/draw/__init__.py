"""Everything microslip draws, from what results.h5 holds (nothing recomputed).

pictures    each analysis type's drawer (its kind names it) and ``render`` (``microslip render``)
backbones   a nonlinear mode: frequency and damping against the level, peaks from it
plots       line plots: FRFs, peak curves, loops, time histories (matplotlib, off screen)
maps        contact-status and static-load maps of the patches (pyvista, off screen)
shapes      deformed sector and full disk at a map point (pyvista)
previews    the mesh previews: bodies, contact patches, full disk (pyvista)
text        the pyvista pictures' text: measured, broken into lines to fit, placed in pixels
files       pictures written whole or not at all
"""
