"""XDMF series of the FE model read back with meshio."""
import meshio
import numpy as np
import pytest

from fenicsx_side.mesh import box_mesh
from fenicsx_side.model import ElasticModel
from fenicsx_side.output import XdmfSeries


@pytest.mark.parametrize("cell", ["hexahedron", "tetrahedron"])
def test_series_reads_back_with_meshio(tmp_path, cell):
    m = ElasticModel(box_mesh((0, 0, 0), (1.0, 0.5, 0.5), (4, 2, 2), cell), 31e9, 0.2, 2400.0)
    rng = np.random.default_rng(0)
    path = tmp_path / "fe.xdmf"
    written = []
    with XdmfSeries(path, m) as series:
        for t in (0.0, 1.5e-6, 3e-6):
            m.u, m.v = rng.normal(size=m.ndof) * 1e-5, rng.normal(size=m.ndof)
            alpha = rng.uniform(size=len(m.nodes))
            series.write(t, point_data={"alpha": alpha})
            written.append((t, m.u.copy(), m.v.copy(), m.stress(), alpha))
            with meshio.xdmf.TimeSeriesReader(path) as reader:  # complete after every frame
                reader.read_points_cells()
                assert reader.num_steps == len(written)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fe", "fe.xdmf"]
    assert sorted(p.name for p in (tmp_path / "fe").iterdir()) == [
        "mesh.h5", "step000000.h5", "step000001.h5", "step000002.h5"]
    check_series(path, m, cell, written)
    # a resumed run keeps the first two frames and writes after them
    resumed = XdmfSeries(path, m, frames=2)
    m.u, m.v = written[2][1], written[2][2]
    resumed.write(written[2][0], point_data={"alpha": written[2][4]})
    check_series(path, m, cell, written)
    with pytest.raises(ValueError, match="step000003.h5 is missing"):
        XdmfSeries(path, m, frames=4)


def check_series(path, m, cell, written):

    with meshio.xdmf.TimeSeriesReader(path) as reader:
        points, cells = reader.read_points_cells()
        assert np.array_equal(points, m.nodes)
        (block,) = cells
        assert block.type == {"hexahedron": "hexahedron", "tetrahedron": "tetra"}[cell]
        assert np.array_equal(np.sort(block.data, axis=1), np.sort(m.cell_nodes, axis=1))
        if cell == "hexahedron":  # VTK order: 0-1-2-3 goes round the bottom face
            x = points[block.data]
            assert np.allclose(x[:, 2] - x[:, 0], x[:, 1] - x[:, 0] + x[:, 3] - x[:, 0])
        assert reader.num_steps == len(written)
        for k, (t, u, v, stress, alpha) in enumerate(written):
            t_read, point_data, cell_data = reader.read_data(k)
            assert t_read == t
            assert np.array_equal(point_data["displacement"], u.reshape(-1, 3))
            assert np.array_equal(point_data["velocity"], v.reshape(-1, 3))
            assert np.array_equal(point_data["alpha"].ravel(), alpha)
            assert np.array_equal(cell_data["stress"][0], stress.tensor.reshape(-1, 9))
            assert np.array_equal(cell_data["von_mises"][0].ravel(), stress.von_mises)
            assert np.array_equal(cell_data["max_principal"][0].ravel(), stress.max_principal)


def test_a_series_without_frames_leaves_no_file(tmp_path):
    m = ElasticModel(box_mesh((0, 0, 0), (1, 1, 1), (1, 1, 1)), 31e9, 0.2, 2400.0)
    XdmfSeries(tmp_path / "fe.xdmf", m).close()
    assert not list(tmp_path.iterdir())


def test_series_path_and_fields_are_checked(tmp_path):
    m = ElasticModel(box_mesh((0, 0, 0), (1, 1, 1), (1, 1, 1)), 31e9, 0.2, 2400.0)
    with pytest.raises(ValueError, match="must end in .xdmf"):
        XdmfSeries(tmp_path / "fe.h5", m)
    with XdmfSeries(tmp_path / "fe.xdmf", m) as series:
        with pytest.raises(ValueError, match="field 'bad': 2 components per row"):
            series.write(0.0, point_data={"bad": np.zeros((len(m.nodes), 2))})
        series.write(1.0)
    with meshio.xdmf.TimeSeriesReader(tmp_path / "fe.xdmf") as reader:
        reader.read_points_cells()
        assert reader.num_steps == 1 and reader.read_data(0)[0] == 1.0  # the bad step left no trace
