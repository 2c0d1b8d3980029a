"""Shared code of the benchmarks (benchmarks/*.py) and the example scenes (examples/*/*.py).

    systems     the FPU chain and the other test systems, its initial conditions and observables
    reference   the reference solution of the FPU chain (SciPy's DOP853) and its own error
    runners     integrator factories, Contexts at a given state, sampled runs, timings of integrator.step()
    progress    progress lines on stderr
    reporting   command lines, JSON, tables and charts
    scenes      the comparison every deterministic FLAVOR scene makes (reference, legacy, FLAVOR, H_eff)
    ensemble    ensembles of independent copies and their statistics (the Langevin scenes)
    helper      the C++ helper benchmarks/step_cost and callgrind instruction counts
    firstorder  the C++ programs of the first-order scenes (van_der_pol, hidden_sde)
    solvation   solvent boxes at a liquid's density

The build copies this package next to openmmflavors (build/python), so PYTHONPATH=build/python finds both.
"""
