"""Orchestrator: couples the YADE (DE) and FEniCSx (FE) partners in a bridging domain.

The coupling algorithm (`bridging`, `multipliers`, `coupling`) is pure numpy/scipy and
works on arrays; only the time loop and the commands know both partners.
"""
