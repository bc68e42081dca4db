"""Benchmarks of the slab models against the performance goals (issue 6): `python -m bench`."""
