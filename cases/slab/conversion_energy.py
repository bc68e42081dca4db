"""The links of the grown zone's first conversion against the same links of the full model at
the same time: `python3 -m cases.slab.conversion_energy --scale small --impactor-speed 40
--fe-material damage --seed 1`.

The coupled model of the zone grown during the run (cases.slab.grow, the case's defaults) runs
to its first conversion; the full model of the same packing runs to the same time (both take
the scale's time step). Links are matched by their spheres' reference positions; compared are
the links between two spheres of the grown DE zone (β = 1, unweighted: the band's are not),
the links the conversion made among them and all of them: their elastic energy (normal and
shear, as the law's elasticEnergy sums it) in the two models. Each model runs in its own
process (one YADE scene per process).
"""
import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from yade_side.transfer import link_energies


def links_among(O, ids, inside=None):
    """The scene's cohesive links between two of the spheres `ids` (and, with `inside`, a mask
    over ids, between two of those): (the interactions, (m, 2) rows of their ends in ids)."""
    links = [i for i in O.interactions if i.isReal and i.phys.isCohesive]
    pairs = np.array([(i.id1, i.id2) for i in links], int).reshape(-1, 2)
    row = np.full(max(ids.max(), pairs.max(initial=0)) + 1, -1)
    row[ids] = np.arange(len(ids))
    ends = row[pairs]
    mine = (ends >= 0).all(axis=1)
    if inside is not None:
        mine[mine] = inside[ends[mine]].all(axis=1)
    return [i for i, m in zip(links, mine) if m], ends[mine]


def pair_keys(ref_a, ref_b, radius):
    """A key per link from its spheres' reference positions, the same in either model."""
    a, b = (np.round(np.asarray(x, float) / radius, 6).tolist() for x in (ref_a, ref_b))
    return [tuple(p + q) if p <= q else tuple(q + p) for p, q in zip(a, b)]


def coupled_phase(spec, out):
    """Run the grown zone's model to its first conversion; save its DE zone's links."""
    from cases.slab.grow import growing_model
    from yade_side import import_yade
    O = import_yade().Omega()
    model, _ = growing_model(spec, log=lambda line: None)
    while not model.conversions and model.steps < spec.steps:
        model.step()
    if not model.conversions:
        raise SystemExit(f"no conversion within the run's {spec.steps} steps")
    new = model.current
    ref = new.spheres.ref_pos
    made = set(map(tuple, new.parts.new_links.ids.tolist()))
    links, ends = links_among(O, new.spheres.ids, new.in_de_zone)
    normal, shear = link_energies(links)
    np.savez(out, a=ref[ends[:, 0]], b=ref[ends[:, 1]], normal=normal, shear=shear,
             new=np.array([(i.id1, i.id2) in made for i in links]), time=O.time,
             step=model.conversions[0]["step"], radius=spec.radius)


def full_phase(spec, saved):
    """Run the full model to the saved time; the same links' energies, as a dict."""
    from cases.slab.model import SlabModel
    from yade_side import import_yade
    from yade_side.scene import settle_forces
    O = import_yade().Omega()
    d = np.load(saved)
    m = SlabModel(spec, "full")
    while O.time + 0.5 * m.dt < float(d["time"]):
        m.step()
    settle_forces()
    ref = m.spheres.ref_pos
    links, ends = links_among(O, m.spheres.ids)
    normal, shear = link_energies(links)
    radius = float(d["radius"])
    energy = dict(zip(pair_keys(ref[ends[:, 0]], ref[ends[:, 1]], radius),
                      zip(normal.tolist(), shear.tolist())))
    keys = pair_keys(d["a"], d["b"], radius)
    # a link the full model has broken (deleted) holds nothing there
    full = np.array([energy.get(k, (0.0, 0.0)) for k in keys])
    new = d["new"]
    out = {"step": int(d["step"]), "time_ms": 1e3 * float(d["time"]), "links": len(keys),
           "new_links": int(new.sum()), "broken_in_full": int(sum(k not in energy for k in keys))}
    for name, mask in (("new", new), ("all", np.ones(len(new), bool))):
        out[name] = {"coupled_normal": float(d["normal"][mask].sum()),
                     "coupled_shear": float(d["shear"][mask].sum()),
                     "full_normal": float(full[mask, 0].sum()),
                     "full_shear": float(full[mask, 1].sum())}
    return out


def main(argv=None):
    from cases.slab import SlabSpec
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scale", default="small")
    p.add_argument("--impactor-speed", type=float, default=40.0)
    p.add_argument("--fe-material", default="damage", choices=("elastic", "damage"))
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--phase", choices=("coupled", "full"), help=argparse.SUPPRESS)
    p.add_argument("--saved", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    spec = SlabSpec(scale=a.scale, impactor_speed=a.impactor_speed, fe_material=a.fe_material,
                    seed=a.seed)
    if a.phase == "coupled":
        return coupled_phase(spec, a.saved)
    if a.phase == "full":
        print(json.dumps(full_phase(SlabSpec(scale=a.scale, impactor_speed=a.impactor_speed,
                                             seed=a.seed), a.saved)))
        return None
    common = [sys.executable, "-m", "cases.slab.conversion_energy", "--scale", a.scale,
              "--impactor-speed", str(a.impactor_speed), "--fe-material", a.fe_material,
              "--seed", str(a.seed)]
    with tempfile.TemporaryDirectory() as tmp:
        saved = str(Path(tmp) / "coupled.npz")
        subprocess.run(common + ["--phase", "coupled", "--saved", saved], check=True)
        got = subprocess.run(common + ["--phase", "full", "--saved", saved], check=True,
                             capture_output=True, text=True).stdout.strip().splitlines()[-1]
    r = json.loads(got)
    print(f"first conversion at step {r['step']} ({r['time_ms']:.3f} ms); the grown DE zone's "
          f"{r['links']} links ({r['broken_in_full']} broken in the full model):")
    for name, what in (("new", f"the {r['new_links']} the conversion made"),
                       ("all", "all of them")):
        f = r[name]
        print(f"  {what}: coupled {f['coupled_normal']:.1f} J normal + {f['coupled_shear']:.1f}"
              f" J shear, full {f['full_normal']:.1f} + {f['full_shear']:.1f} J")
    return None


if __name__ == "__main__":
    main()
