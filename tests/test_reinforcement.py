"""Bar layouts (cases.reinforcement): geometry, refused layouts, transformed section."""
import math

import numpy as np
import pytest

from cases.reinforcement import Layer, bar_layout, layer_from_dict, transformed_section

BOX = ((0.0, 0.0, 0.0), (2.5, 2.0, 0.28))


def mesh_layers():
    """A typical two-layer bottom mesh: 12 mm bars at 0.15 m both ways, 30 mm concrete cover
    to the lower layer (axes at 36 mm), the upper layer resting on it (axes 12 mm higher)."""
    return [Layer(diameter=0.012, spacing=0.15, direction="x", cover=0.036),
            Layer(diameter=0.012, spacing=0.15, direction="y", cover=0.048)]


def test_mesh_geometry():
    bars = bar_layout(mesh_layers(), *BOX)
    x, y = bars.layer == 0, bars.layer == 1
    # bars along x: across y in [cover, 2 − cover], as many as fit at 0.15 m, centred
    n_x = math.floor((2.0 - 2 * 0.036) / 0.15) + 1
    assert x.sum() == n_x and y.sum() == math.floor((2.5 - 2 * 0.048) / 0.15) + 1
    assert np.allclose(bars.start[x, 0], 0.036) and np.allclose(bars.end[x, 0], 2.5 - 0.036)
    assert np.allclose(np.diff(np.sort(bars.start[x, 1])), 0.15)
    assert np.mean(bars.start[x, 1]) == pytest.approx(1.0)
    assert np.allclose(bars.start[x, 2], 0.036) and np.allclose(bars.start[y, 2], 0.048)
    assert np.allclose(bars.axis[x], [1, 0, 0]) and np.allclose(bars.axis[y], [0, 1, 0])
    assert bars.mass() == pytest.approx(7850 * math.pi * 0.006**2 * bars.length.sum())


def test_top_layer_is_measured_from_the_top_face():
    bars = bar_layout([Layer(0.01, 0.2, "x", 0.05, face="top")], *BOX)
    assert np.allclose(bars.start[:, 2], 0.28 - 0.05)


@pytest.mark.parametrize("change, message", [
    (dict(cover=0.005), r"reinforcement\[0\]\.cover = 0\.005 m is below the bar radius 0\.006"),
    (dict(cover=0.3), r"reinforcement\[0\]\.cover = 0\.3 m puts the bars outside the concrete"),
    (dict(spacing=0.0), r"reinforcement\[0\]\.spacing must be a positive number, got 0\.0"),
    (dict(spacing=0.01), r"reinforcement\[0\]\.spacing = 0\.01 m is below the bar diameter"),
    (dict(direction="z"), r"reinforcement\[0\]\.direction must be one of \('x', 'y'\), got 'z'"),
    (dict(diameter=-0.01), r"reinforcement\[0\]\.diameter must be a positive number, got -0\.01"),
    (dict(face="side"), r"reinforcement\[0\]\.face must be one of"),
    (dict(hardening=-1e9), r"reinforcement\[0\]\.hardening must be a number in \[0, young\) "
                           r"\(Pa\), got -1000000000\.0"),
])
def test_bad_layers_are_refused_in_one_line(change, message):
    layer = dict(diameter=0.012, spacing=0.15, direction="x", cover=0.036) | change
    with pytest.raises(ValueError, match=message) as err:
        bar_layout([Layer(**layer)], *BOX)
    assert "\n" not in str(err.value)


def test_crossing_layers_and_case_file_keys_are_refused():
    with pytest.raises(ValueError, match=r"reinforcement\[1\]\.cover = 0\.04 m: its bars cross"):
        bar_layout([Layer(0.012, 0.15, "x", 0.036), Layer(0.012, 0.15, "y", 0.04)], *BOX)
    with pytest.raises(ValueError, match=r"slab\.toml reinforcement\[2\]: unknown key 'spacin'"):
        layer_from_dict(dict(diameter=0.012, spacin=0.1, direction="x", cover=0.04),
                        "slab.toml reinforcement[2]")
    with pytest.raises(ValueError, match=r"missing key 'cover'"):
        layer_from_dict(dict(diameter=0.012, spacing=0.1, direction="x"))
    with pytest.raises(ValueError, match="narrow|no room"):
        bar_layout([Layer(0.012, 0.15, "x", 1.2)], (0, 0, 0), (2.5, 2.0, 2.8))


def test_transformed_section():
    """No steel: the plain section (depth/2, b h³/12). Steel at the centroid: I + 0 and the
    axis unmoved. One bar off-centre: parallel axis theorem by hand."""
    b, h, ec, es = 0.2, 0.28, 31e9, 200e9
    assert transformed_section(b, h, ec, [0.1], [0.0], es) == pytest.approx((h / 2, b * h**3 / 12))
    y, i = transformed_section(b, h, ec, [h / 2], [1e-3], es)
    assert y == pytest.approx(h / 2) and i == pytest.approx(b * h**3 / 12)
    a, d = 4e-4, 0.24
    extra = (es / ec - 1) * a
    y_exp = (b * h * h / 2 + extra * d) / (b * h + extra)
    i_exp = b * h**3 / 12 + b * h * (h / 2 - y_exp) ** 2 + extra * (d - y_exp) ** 2
    assert transformed_section(b, h, ec, [d], [a], es) == pytest.approx((y_exp, i_exp))
