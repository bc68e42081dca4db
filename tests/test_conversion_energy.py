"""The link matching of cases.slab.conversion_energy: a link's key is its two spheres'
reference positions (the same bits in both models: one packing), whichever end comes first,
and tells links apart."""
import numpy as np

from cases.slab.conversion_energy import pair_keys


def test_a_links_key_does_not_depend_on_the_order_of_its_ends():
    rng = np.random.default_rng(3)
    a, b = rng.uniform(0, 1, (50, 3)), rng.uniform(0, 1, (50, 3))
    keys = pair_keys(a, b, 0.01)
    assert keys == pair_keys(b, a, 0.01)
    assert len(set(keys)) == 50
