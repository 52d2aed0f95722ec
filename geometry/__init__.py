"""microslip: Gmsh parametric models -> tagged meshes (no physics here)."""
