"""FEniCSx partner: linear-elastic, lumped-mass, explicit FE model (dolfinx 0.5.2).

Knows nothing of the DE side.
"""
