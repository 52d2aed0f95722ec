"""microslip.pipeline: the stages from a meshed geometry to the forced response.

The sub-packages read as the data flow; imports run one way, from the top down:

    cli        the ``microslip`` command
    bench      benchmarks and small demos
    app        case files, validation, the structural stage, run, results, plots
    solve      harmonic balance, continuation, response curves, time integration
    friction   harmonics layout, contact laws A-D, the compiled return map
    fe         K, M, cyclic matrices, Craig-Bampton, contact-patch stiffness, sparse solvers

``fe`` and ``friction`` are independent of each other; ``fe`` reads meshes from
:mod:`microslip.geometry`, the bottom of the house.
"""
