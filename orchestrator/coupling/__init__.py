"""The coupling core: bridging geometry and weights, the multipliers and the correction, the
energy the coupling exchanges, the relaxation rule. Pure numpy/scipy, arrays in and arrays out:
it imports nothing else of the project, and sees the partners only through the contracts of
`orchestrator.contracts` (duck-typed here)."""
