"""The one writer (common.files): whole files or none, with the mode the user's umask gives."""
import json
import os
import stat

import numpy as np
import pytest

from common import files


@pytest.fixture(params=[0o022, 0o077, 0o002])
def umask(request):
    old = os.umask(request.param)
    yield request.param
    os.umask(old)


def test_every_kind_of_file_gets_the_umask_mode(tmp_path, umask):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    files.write_json(tmp_path / "a.json", {"x": np.float64(1.5), "y": np.arange(2)})
    files.write_csv(tmp_path / "b.csv", ["t", "x"], [[0.0, 1.0]])
    files.write_toml(tmp_path / "c.toml", {"case": {"name": "x"}}, comment="as run")
    files.save_npz(tmp_path / "d.npz", a=np.ones(3))
    files.save_figure(plt.figure(), tmp_path / "e.png")
    with files.atomic(tmp_path / "f.vtu") as tmp:
        tmp.write_text("frame")
    for path in tmp_path.iterdir():
        assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask, path.name
    assert json.loads((tmp_path / "a.json").read_text()) == {"x": 1.5, "y": [0, 1]}
    assert (tmp_path / "c.toml").read_text().startswith("# as run\n")
    assert np.load(tmp_path / "d.npz")["a"].tolist() == [1, 1, 1]
    assert (tmp_path / "e.png").read_bytes()[:4] == b"\x89PNG"


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "summary.json"
    files.write_json(path, {"old": 1})
    with pytest.raises(TypeError):
        files.write_json(path, {"new": object()})
    assert json.loads(path.read_text()) == {"old": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]
