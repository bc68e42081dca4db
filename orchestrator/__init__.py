"""Orchestrator: builds a model from a case's description, runs its time loop, and couples the
YADE (DE) and FEniCSx (FE) partners in a bridging domain.

The coupling core (`orchestrator.coupling`) is pure numpy/scipy and works on arrays; the
builder and the run loop know both partners; the command line above is the `cli` package.
"""
