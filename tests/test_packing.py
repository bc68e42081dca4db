"""Deterministic packings: a packing depends on its defining arguments only, never on what the
cache held before (issue 14)."""
import os
import shutil
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from yade_side.packing import cell_key, cell_path, dense_box_packing, sphere_arrays

LO, HI, R, N = (0.0, 0.0, 0.0), (0.24, 0.2, 0.16), 0.02, 300  # ~70 spheres, cells of 300


def build(cache, monkeypatch, radius=R, seed=1, hi=HI):
    monkeypatch.setenv("DEM_FEM_CACHE", str(cache))
    monkeypatch.setattr("yade_side.packing.SHIPPED", cache / "none")   # compact, never ship
    c, r = sphere_arrays(dense_box_packing(LO, hi, radius, seed=seed, spheres_in_cell=N))
    return np.column_stack([c, r])


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        cache = tmp_path_factory.mktemp("cache-ref")
        return cache, build(cache, mp)


def test_same_seed_in_fresh_caches_is_bit_identical(reference, tmp_path, monkeypatch):
    again = build(tmp_path, monkeypatch)
    assert again.shape[0] > 40 and again.tobytes() == reference[1].tobytes()


@pytest.fixture(scope="module")
def prefilled(tmp_path_factory):
    """A cache holding packings of another radius and of other seeds."""
    with pytest.MonkeyPatch.context() as mp:
        cache = tmp_path_factory.mktemp("cache-prefilled")
        return cache, {(radius, seed): build(cache, mp, radius=radius, seed=seed)
                       for radius, seed in [(0.016, 1), (R, 2), (R, 3)]}


def test_cache_prefilled_with_other_packings_changes_nothing(reference, prefilled, monkeypatch):
    """YADE's own memo would scale a cached cell of another radius; this cache must not."""
    assert build(prefilled[0], monkeypatch).tobytes() == reference[1].tobytes()


def test_other_seeds_give_other_realisations(reference, prefilled):
    ref, a, b = reference[1], prefilled[1][R, 2], prefilled[1][R, 3]
    for x, y in [(a, ref), (b, ref), (a, b)]:
        assert x.shape != y.shape or not np.array_equal(x, y)
    # the same statistical packing: counts differ by a boundary layer's fluctuation only
    assert abs(len(a) - len(ref)) < 0.15 * len(ref) and abs(len(b) - len(ref)) < 0.15 * len(ref)


def test_cached_cell_tiles_exactly_as_yade_randomdensepack(reference, tmp_path):
    """The cached cell, tiled over the box, is exactly YADE's randomDensePack (no memo) run in a
    one-thread process."""
    out = tmp_path / "yade.npy"
    script = textwrap.dedent(f"""
        import sys, numpy as np
        sys.path.insert(0, "/usr/lib/x86_64-linux-gnu/yade-double/py")
        from yade import pack
        sp = pack.randomDensePack(pack.inAlignedBox({LO}, {HI}), radius={R}, rRelFuzz=0.0,
                                  spheresInCell={N}, seed=1, returnSpherePack=True)
        np.save({str(out)!r}, np.array([(c[0], c[1], c[2], r) for c, r in sp], float))
    """)
    subprocess.run([sys.executable, "-c", script], env=dict(os.environ, OMP_NUM_THREADS="1"),
                   check=True, capture_output=True)
    assert np.load(out).tobytes() == reference[1].tobytes()


def test_corrupt_cache_file_is_rebuilt_with_a_message_naming_it(reference, monkeypatch, capfd):
    cache, ref = reference
    monkeypatch.setenv("DEM_FEM_CACHE", str(cache))
    files = list((cache / "cells").glob("*.npz"))
    assert len(files) == 1
    files[0].write_bytes(files[0].read_bytes()[:200])
    again = build(cache, monkeypatch)
    err = capfd.readouterr().err.strip().splitlines()
    assert [line for line in err if line.startswith("warning:")] == [
        line for line in err if str(files[0]) in line]
    assert any(f"packing cache file {files[0]} is unusable, rebuilding it" in line for line in err)
    assert again.tobytes() == ref.tobytes()
    assert oct(files[0].stat().st_mode & 0o777) == "0o644"


def test_cache_file_of_another_cell_is_not_used(reference, prefilled, tmp_path, monkeypatch,
                                                capfd):
    """A file under a cell's name that holds another cell (copied, or a hash collision) is
    rebuilt, not used."""
    monkeypatch.setenv("DEM_FEM_CACHE", str(prefilled[0]))
    seed2 = cell_path(cell_key(np.subtract(HI, LO), R, 0.0, 2, N))
    monkeypatch.setenv("DEM_FEM_CACHE", str(tmp_path))
    seed1 = cell_path(cell_key(np.subtract(HI, LO), R, 0.0, 1, N))
    shutil.copy(seed2, seed1)
    assert build(tmp_path, monkeypatch).tobytes() == reference[1].tobytes()
    assert f"packing cache file {seed1} is unusable, rebuilding it: it holds another cell" \
        in capfd.readouterr().err


def test_unusable_cache_folder_is_refused_in_one_line(tmp_path, monkeypatch):
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("DEM_FEM_CACHE", str(tmp_path / "file" / "cache"))
    with pytest.raises(ValueError, match=r"^cache folder .*file/cache/cells \(DEM_FEM_CACHE\) "
                                         r"cannot be made: Not a directory$"):
        dense_box_packing(LO, HI, R, spheres_in_cell=N)


@pytest.mark.parametrize("kw, word", [({"seed": -1}, "seed"), ({"seed": True}, "seed"),
                                      ({"seed": 1.5}, "seed"), ({"rel_fuzz": 1.0}, "fuzz"),
                                      ({"radius": 0.0}, "radius"), ({"radius": 0.07}, "thinner")])
def test_bad_arguments_are_refused_in_one_line(kw, word):
    args = {"radius": R, **kw}
    with pytest.raises(ValueError, match=word) as err:
        dense_box_packing(LO, HI, args.pop("radius"), spheres_in_cell=N, **args)
    assert "\n" not in str(err.value)


def test_an_empty_cache_variable_means_the_users_cache_not_the_working_folder(tmp_path,
                                                                               monkeypatch):
    from yade_side.packing import cache_dir
    monkeypatch.setenv("DEM_FEM_CACHE", "")
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    assert cache_dir() == tmp_path / ".cache" / "yade-fenicsx-coupling"
    assert not (tmp_path / "cells").exists()


def test_a_shipped_cell_is_read_when_the_cache_lacks_it(reference, tmp_path, monkeypatch):
    """A fresh cache with the reference cell among the shipped ones: no compaction (the child
    would fail: no python there), the same packing."""
    shipped = tmp_path / "shipped"
    shipped.mkdir()
    key = cell_key(np.subtract(HI, LO), R, 0.0, 1, N)
    monkeypatch.setenv("DEM_FEM_CACHE", str(reference[0]))
    shutil.copy(cell_path(key), shipped / cell_path(key).name)
    monkeypatch.setenv("DEM_FEM_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr("yade_side.packing.SHIPPED", shipped)
    monkeypatch.setattr("sys.executable", str(tmp_path / "no-python"))
    c, r = sphere_arrays(dense_box_packing(LO, HI, R, seed=1, spheres_in_cell=N))
    assert np.column_stack([c, r]).tobytes() == reference[1].tobytes()


@pytest.mark.slow
def test_every_shipped_cell_is_what_its_key_compacts_to(tmp_path):
    """The cells shipped in yade_side/cells, compacted afresh from the key each holds: the same
    bits (minutes: ~10 s per cell)."""
    import json
    from yade_side.packing import SHIPPED, _compact_in_child, _read_cell
    files = sorted(SHIPPED.glob("*.npz"))
    assert files, f"no shipped cells in {SHIPPED}"
    for path in files:
        with np.load(path) as f:
            key = json.loads(str(f["key"]))
        assert path.name == cell_path(key).name        # named by its key's hash
        fresh = tmp_path / path.name
        _compact_in_child(key, fresh)
        for a, b in zip(_read_cell(path, key), _read_cell(fresh, key)):
            assert a.tobytes() == b.tobytes(), path.name
