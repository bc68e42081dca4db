"""The FE twin of the spheres' uniaxial tests: the slab's FE damage law, on cells of the slab's
mesh size, run on the calibration's specimens and judged against the spheres' curves of the
scale's calibration record (cases/slab/calibrations).

- Specimen: the record's box (0.56 × 0.56 × 0.28 m), an even number of cells along its length
  nearest the slab's in-plane cell size, the slab's cells through its thickness.
- Tension: the spheres' separation test is notched on its two cut sides at mid-length (10 %
  of the width each, yade_side.fracture); the FE's mid-length nodes are drawn in to the same
  ligament. Compression: unnotched, as the spheres' test.
- Cycle (not in the record: the spheres run it here, yade_side.cyclic, on the record's
  packing and CPM set): the notched specimen pulled to 3 × the tension peak's strain (a
  crack), pushed to half fc's elastic strain in compression (the crack shut), pulled to
  6 × the peak strain; spheres and FE at the compression test's rate.
- Bending (not in the record either: cases/slab/bending.py): the slab's 0.3 m strip over its
  span, its mid-span patch pushed down at 20 mm/s to 6 mm, in the slab's packing and CPM set
  and in the FE law on the slab's grid; force against the patch's travel.
- Loading: the x = 0 face held along x, the x = L face driven at the spheres' strain rate,
  every node starting on the uniform strain rate's velocity field (no shock); explicit steps
  at half the critical one. Stress = end force / nominal section, strain = end displacement /
  L, as the spheres' strainer measures them.
- Judged: the stress-strain nRMS up to the spheres' peak (the RMS of the FE's stress minus the
  spheres' at the spheres' samples, over the spheres' peak), the peaks, and the work ∫σ dε ×
  volume up to the spheres' last sample (for a test to separation, the energy to failure).
  The cycle: the nRMS over its whole path (matched by the strain travelled, over the
  spheres' largest |σ|) and each leg's extreme stress. Bending: as tension, with force for
  stress and travel for strain (work in J).
"""
from dataclasses import dataclass

import numpy as np

NOTCH = 0.1          # the separation test's notch on each cut side, × the width
RATE_SPEEDUP = 10.0  # FE loading rate over the spheres' (quasi-static: its transit time is
                     # ~0.2 ms against ≥ 20 ms of loading)
CYCLE = (3.0, -0.5, 6.0)  # the cycle's targets: × the tension peak's strain, × fc / E, × it


@dataclass
class TwinRun:
    mode: str
    strain: np.ndarray
    stress: np.ndarray
    dissipated: float      # J, by the FE damage law
    cells: tuple           # cells along x, y, z
    h: float               # the cells' length along x (m)


def specimen_mesh(size, h_plane, nz, notch):
    """A box of `size`, cells along x: the even number nearest size[0]/h_plane (a node plane at
    mid-length), along y: nearest size[1]/h_plane, nz through the thickness; with `notch` the
    mid-length nodes' y drawn in to [notch W, (1 − notch) W]."""
    from dolfinx import mesh
    from mpi4py import MPI
    nx = max(2, 2 * round(size[0] / (2 * h_plane)))
    ny = max(1, round(size[1] / h_plane))
    msh = mesh.create_box(MPI.COMM_SELF, [[0, 0, 0], list(size)], [nx, ny, nz],
                          cell_type=mesh.CellType.hexahedron)
    if notch:
        x = msh.geometry.x
        mid = np.isclose(x[:, 0], size[0] / 2)
        x[mid, 1] = notch * size[1] + (1 - 2 * notch) * x[mid, 1]
    return msh, (nx, ny, nz)


def run_specimen(law, rho, size, h_plane, nz, mode, path, rate, samples=400):
    """Drive the FE specimen of `mode` ('tension', 'compression' or 'cyclic': notched but in
    compression) through the strains `path` (in turn) at `rate` (1/s); return a TwinRun
    sampled about `samples` times."""
    from fenicsx_side.damaged import DamageModel
    from fenicsx_side.model import face
    msh, cells = specimen_mesh(size, h_plane, nz, 0.0 if mode == "compression" else NOTCH)
    length = size[0]
    m = DamageModel(msh, law, rho, dirichlet=[(face(0, 0.0), (0,)), (face(0, length), (0,))])
    driven = np.flatnonzero(m.fixed & np.isclose(np.repeat(m.nodes[:, 0], 3), length))
    dt = 0.5 * m.critical_dt()
    travel = np.abs(np.diff(np.concatenate([[0.0], path]))).sum()
    every = max(1, int(travel / rate / dt) // samples)
    speed = np.copysign(rate * length, path[0])
    field = m.nodes * (speed / length) * np.array([1.0, -law.poisson, -law.poisson])
    field[:, 1:] -= field[:, 1:].mean(axis=0)
    m.v = np.where(m.fixed, 0.0, field.ravel())
    section = size[1] * size[2]
    strain, stress, k, held = [0.0], [0.0], 0, 0.0
    for target in path:
        new = np.copysign(rate * length, target - strain[-1])
        m.correct(driven, np.full(driven.size, (new - held) * dt), dt)   # the ends' velocity
        held = new
        while (m.u[driven].mean() / length - target) * np.sign(new) < 0:
            m.predict(dt)
            k += 1
            if k % every == 0:
                strain.append(m.u[driven].mean() / length)
                stress.append(m.internal_force()[driven].sum() / section)
        strain.append(m.u[driven].mean() / length)
        stress.append(m.internal_force()[driven].sum() / section)
    return TwinRun(mode, np.array(strain), np.array(stress), m.dissipated, cells,
                   length / cells[0])


def judge(spheres_strain, spheres_stress, fe, volume):
    """The twin's figures against the spheres' curve (signed as recorded)."""
    sign = -1.0 if fe.mode == "compression" else 1.0
    e_s, s_s = sign * np.asarray(spheres_strain), sign * np.asarray(spheres_stress)
    e_f, s_f = sign * fe.strain, sign * fe.stress
    peak = int(np.argmax(s_s))
    upto = slice(0, peak + 1)
    on_fe = np.interp(e_s[upto], e_f, s_f)
    nrms = float(np.sqrt(np.mean((on_fe - s_s[upto]) ** 2)) / s_s[peak])
    end = e_s[-1]
    keep = e_f <= end
    work = lambda e, s: float(np.trapz(s, e)) * volume
    e_fe = np.append(e_f[keep], end)
    s_fe = np.append(s_f[keep], np.interp(end, e_f, s_f))
    w_s, w_f = work(e_s, s_s), work(e_fe, s_fe)
    return dict(nrms_to_peak=nrms, peak_spheres=float(s_s[peak]), peak_fe=float(s_f.max()),
                strain_at_peak_spheres=float(e_s[peak]),
                strain_at_peak_fe=float(e_f[np.argmax(s_f)]), end_strain=float(end),
                work_spheres_J=w_s, work_fe_J=w_f, work_ratio=w_f / w_s,
                dissipated_fe_J=fe.dissipated)


def travel(strain):
    """The strain travelled along a path: Σ |Δε| from its start."""
    return np.concatenate([[0.0], np.cumsum(np.abs(np.diff(strain)))])


def judge_cycle(spheres_strain, spheres_stress, fe, targets):
    """The cycle's figures: nRMS over the path (the FE's stress at the spheres' strain
    travelled, minus theirs, RMS over the spheres' largest |σ|) and per leg the extreme
    stress (the largest on a leg that pulls, the smallest on one that pushes)."""
    e_s, s_s = np.asarray(spheres_strain), np.asarray(spheres_stress)
    t_s, t_f = travel(e_s), travel(fe.strain)
    on_fe = np.interp(t_s, t_f, fe.stress)
    nrms = float(np.sqrt(np.mean((on_fe - s_s) ** 2)) / np.abs(s_s).max())
    ends = travel(np.concatenate([[0.0], targets]))
    legs = []
    for k, target in enumerate(targets):
        pick = np.max if target > (targets[k - 1] if k else 0.0) else np.min
        leg = lambda t, s: float(pick(s[(t >= ends[k]) & (t <= ends[k + 1])]))
        legs.append(dict(target=float(target), spheres=leg(t_s, s_s), fe=leg(t_f, fe.stress)))
    return dict(nrms_path=nrms, legs=legs, dissipated_fe_J=fe.dissipated)


def cycle_targets(record):
    """CYCLE in strains of the record's specimen."""
    t = record["curves"]["tension"]
    peak_strain = t["strain"][int(np.argmax(t["stress"]))]
    m = record["measured"]
    return (CYCLE[0] * peak_strain, CYCLE[1] * m["fc"] / m["E_ends"], CYCLE[2] * peak_strain)


def spheres_cycle(record, seed=1):
    """The cycle on the record's specimen (packing `seed`, as `calibrate` packs it) and CPM
    set, at its compression test's rate; YADE must be imported."""
    from yade_side import calibration as cal
    from yade_side.cyclic import cyclic_test
    from yade_side.material import ConcreteParams
    size = tuple(record["size"])
    sample = cal.packed_sample(record["radius"], size, seed=seed)
    if len(sample.radii) != record["spheres"]:
        raise ValueError(f"the cycle's specimen has {len(sample.radii)} spheres, the record's "
                         f"{record['spheres']}: not the record's packing")
    loading = cal.Loading(**record["loading"])
    return cyclic_test(sample, ConcreteParams(**record["params"]), cycle_targets(record),
                       loading.strain_rate, loading)


def twin(spec, record, cycle=None, bending=None, rate_speedup=RATE_SPEEDUP):
    """The record's specimens with the slab's FE law (spec: a SlabSpec with fe_material
    'damage'), the cycle if the spheres' one is given (spheres_cycle) and the bending strip if
    the spheres' (travel, force) is. Returns {mode: (TwinRun, figures)}."""
    from cases.slab.zone import slab_grid
    from cases.slab.scales import SLAB
    from fenicsx_side.damage_law import ConcreteDamage
    law = ConcreteDamage(**spec.damage_law())
    grid = slab_grid(spec)
    size = tuple(record["size"])
    nz = max(1, round(size[2] / (SLAB[2] / grid.n[2])))
    loading = record["loading"]
    volume = float(np.prod(size))
    run = lambda mode, path, rate: run_specimen(law, spec.density, size, grid.h, nz, mode,
                                                path, rate)
    out = {}
    for mode, rate, sign in (("compression", loading["strain_rate"], -1.0),
                             ("tension", loading["tension_rate"], 1.0)):
        curve = record["curves"][mode]
        fe = run(mode, [sign * 1.02 * abs(curve["strain"][-1])], rate * rate_speedup)
        out[mode] = (fe, judge(curve["strain"], curve["stress"], fe, volume))
    if cycle is not None:
        fe = run("cyclic", cycle["targets"], loading["strain_rate"])
        out["cyclic"] = (fe, judge_cycle(cycle["strain"], cycle["stress"], fe,
                                         cycle["targets"]))
    if bending is not None:
        from cases.slab.bending import BEND_SPEED, bending_to_failure_fe
        travel, force = bending
        t, f, dissipated, cells = bending_to_failure_fe(spec, law, BEND_SPEED, travel[-1])
        fe = TwinRun("bending", t, f, dissipated, cells, grid.h)
        out["bending"] = (fe, judge(travel, force, fe, 1.0))
    return out


def plot(path, record, result, title, cycle=None, bending=None):
    """The specimens' curves, spheres and FE overlaid (the cycle's and the bending strip's if
    given)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from common.files import save_figure
    modes = (("compression", "tension") + (("cyclic",) if cycle is not None else ())
             + (("bending",) if bending is not None else ()))
    fig, axes = plt.subplots(1, len(modes), figsize=(5 * len(modes), 4.2))
    for ax, mode in zip(axes, modes):
        fe, fig_ = result[mode]
        if mode == "bending":
            ax.plot(1e3 * bending[0], 1e-3 * bending[1], "k", label="spheres (CPM)")
            ax.plot(1e3 * fe.strain, 1e-3 * fe.stress, "C3",
                    label=f"FE, {fe.cells[0]}×{fe.cells[1]}×{fe.cells[2]} cells")
            ax.set_xlabel("patch travel (mm)")
            ax.set_ylabel("force (kN)")
            ax.set_title(f"bending strip: nRMS to peak {fig_['nrms_to_peak']:.2f}, work ratio "
                         f"{fig_['work_ratio']:.2f}", fontsize=9)
            ax.legend(fontsize=8)
            continue
        curve = cycle if mode == "cyclic" else record["curves"][mode]
        sign = -1.0 if mode == "compression" else 1.0
        ax.plot(sign * 1e3 * np.asarray(curve["strain"]), sign * 1e-6 * np.asarray(
            curve["stress"]), "k", label="spheres (CPM)")
        ax.plot(sign * 1e3 * fe.strain, sign * 1e-6 * fe.stress, "C3",
                label=f"FE, {fe.cells[0]}×{fe.cells[1]}×{fe.cells[2]} cells")
        if mode == "cyclic":
            ax.set_xlabel("strain (‰)")
            ax.set_ylabel("stress (MPa)")
            ax.set_title(f"tension-compression cycle: nRMS over the path "
                         f"{fig_['nrms_path']:.2f}", fontsize=9)
        else:
            ax.set_xlabel(f"{'extension' if sign > 0 else 'shortening'} strain (‰)")
            ax.set_ylabel(f"{mode} stress (MPa)")
            ax.set_title(f"{mode}: nRMS to peak {fig_['nrms_to_peak']:.2f}, work ratio "
                         f"{fig_['work_ratio']:.2f}", fontsize=9)
        ax.legend(fontsize=8)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)
