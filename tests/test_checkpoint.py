"""Saving and restoring a damaged CPM scene (yade_side.checkpoint)."""
import numpy as np
import pytest

from yade_side import import_yade
from yade_side.bulk import BodySet
from yade_side.checkpoint import CheckpointError, load_scene, save_scene
from yade_side.memory import history_values
from yade_side.material import ConcreteParams, cpm_material
from yade_side.packing import add_spheres, dense_box_packing, sphere_arrays
from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene

STEPS = 60


def stretched_block():
    """A CPM cube pulled apart along z at ±20 m/s: its links crack in tension, and the halves
    separate, so no new contact forms after the start."""
    reset_scene()
    centres, radii = sphere_arrays(dense_box_packing((0, 0, 0), (0.3, 0.3, 0.3), 0.02))
    ids = add_spheres(centres, radii, cpm_material(ConcreteParams(), 0.6))
    cpm_engines(dt_safety=0.3)
    create_cohesive_links()
    bodies = BodySet(ids)
    bodies.set_velocity(np.column_stack([np.zeros((len(ids), 2)),
                                         np.where(centres[:, 2] > 0.15, 20.0, -20.0)]))
    return ids


def run(steps, ids, bodies=None):
    O = import_yade().Omega()
    bodies = bodies or BodySet(ids)
    out = []
    for _ in range(steps):
        O.step()
        out.append(bodies.read().copy())
    return np.array(out)


def links():
    O = import_yade().Omega()
    return {(i.id1, i.id2): history_values(i.phys) for i in O.interactions if i.isReal}


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ckpt") / "scene"
    ids = stretched_block()
    run(STEPS, ids)
    before = links()
    save_scene(folder)
    after = run(STEPS, ids)
    return folder, ids, before, after


def test_damage_history_is_restored_bit_for_bit(saved):
    folder, ids, before, _ = saved
    assert any(v[0] > 0 for v in before.values())  # partly damaged links (omega): a history
    load_scene(folder)
    restored = links()
    assert restored.keys() == before.keys()
    for key, values in before.items():
        assert np.array_equal(restored[key].view(np.int64), values.view(np.int64)), key


def test_a_restored_run_continues_identically(saved):
    """...also read through a BodySet made before loading (it is pointed at the new bodies)."""
    folder, ids, _, after = saved
    bodies = BodySet(ids)
    load_scene(folder)
    again = run(STEPS, ids, bodies)
    assert np.array_equal(again.view(np.int64), after.view(np.int64))


def test_without_the_history_yade_alone_heals_the_links(saved):
    """What O.load alone does: the links restart undamaged, the run goes elsewhere."""
    folder, ids, before, after = saved
    O = import_yade().Omega()
    O.load(str(folder / "scene.yade.gz"))
    assert all(i.phys.omega == 0 for i in O.interactions if i.isReal)
    again = run(STEPS, ids)
    assert np.abs(again - after)[:, :, 3:6].max() > 1e-3  # m/s: far beyond round-off


def test_a_mismatched_checkpoint_is_refused(saved, tmp_path):
    folder, *_ = saved
    with pytest.raises(CheckpointError, match="has no cpm_history.npz"):
        bad = tmp_path / "bad"
        bad.mkdir()
        (bad / "scene.yade.gz").write_bytes((folder / "scene.yade.gz").read_bytes())
        load_scene(bad)
    with np.load(folder / "cpm_history.npz") as data:
        np.savez(tmp_path / "bad" / "cpm_history.npz", pairs=data["pairs"][1:],
                 history=data["history"][1:], offset=data["offset"])
    with pytest.raises(CheckpointError, match="CPM links"):
        load_scene(tmp_path / "bad")


def test_links_at_rest_checkpoint_too(tmp_path):
    """Right after the links are made every link holds the same, mostly zero, history: its
    block matches at several places of a CpmPhys, and the verified layout decides."""
    stretched_block()
    before = links()
    save_scene(tmp_path / "scene")
    load_scene(tmp_path / "scene")
    after = links()
    assert before.keys() == after.keys()
    assert all(np.array_equal(before[k].view(np.int64), after[k].view(np.int64)) for k in before)
