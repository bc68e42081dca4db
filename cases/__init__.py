"""Ready cases: wave1d (the 1D reflection study), slab (the paper's slab impact)."""
