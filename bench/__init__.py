"""Benchmarks of the slab models against the performance goals: `python -m bench`."""
