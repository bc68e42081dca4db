"""The FE twin of the spheres' uniaxial tests: the slab's FE damage law, on cells of the slab's
mesh size, run on the calibration's specimens and judged against the spheres' curves of the
scale's calibration record (cases/slab/calibrations).

- Specimen: the record's box (0.56 × 0.56 × 0.28 m), an even number of cells along its length
  nearest the slab's in-plane cell size, the slab's cells through its thickness.
- Tension: the spheres' separation test is notched on its two cut sides at mid-length (10 %
  of the width each, yade_side.fracture); the FE's mid-length nodes are drawn in to the same
  ligament. Compression: unnotched, as the spheres' test.
- Loading: the x = 0 face held along x, the x = L face driven at the spheres' strain rate,
  every node starting on the uniform strain rate's velocity field (no shock); explicit steps
  at half the critical one. Stress = end force / nominal section, strain = end displacement /
  L, as the spheres' strainer measures them.
- Judged: the stress-strain nRMS up to the spheres' peak (the RMS of the FE's stress minus the
  spheres' at the spheres' samples, over the spheres' peak), the peaks, and the work ∫σ dε ×
  volume up to the spheres' last sample (for a test to separation, the energy to failure).
"""
from dataclasses import dataclass

import numpy as np

NOTCH = 0.1          # the separation test's notch on each cut side, × the width
RATE_SPEEDUP = 10.0  # FE loading rate over the spheres' (quasi-static: its transit time is
                     # ~0.2 ms against ≥ 20 ms of loading)


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


def run_specimen(law, rho, size, h_plane, nz, mode, rate, end_strain, samples=400):
    """Drive the FE specimen in `mode` ('tension' or 'compression') at `rate` (1/s) to
    |strain| = end_strain; return a TwinRun sampled `samples` times."""
    from fenicsx_side.damaged import DamageModel
    from fenicsx_side.model import face
    msh, cells = specimen_mesh(size, h_plane, nz, NOTCH if mode == "tension" else 0.0)
    length = size[0]
    m = DamageModel(msh, law, rho, dirichlet=[(face(0, 0.0), (0,)), (face(0, length), (0,))])
    driven = np.flatnonzero(m.fixed & np.isclose(np.repeat(m.nodes[:, 0], 3), length))
    sign = 1.0 if mode == "tension" else -1.0
    speed = sign * rate * length
    dt = 0.5 * m.critical_dt()
    steps = int(np.ceil(end_strain / rate / dt))
    every = max(1, steps // samples)
    field = m.nodes * (speed / length) * np.array([1.0, -law.poisson, -law.poisson])
    field[:, 1:] -= field[:, 1:].mean(axis=0)
    m.v = np.where(m.fixed, 0.0, field.ravel())
    m.correct(driven, np.full(driven.size, speed * dt), dt)
    section = size[1] * size[2]
    strain, stress = [0.0], [0.0]
    for k in range(1, steps + 1):
        m.predict(dt)
        if k % every == 0 or k == steps:
            strain.append(m.u[driven].mean() / length)
            stress.append(m.internal_force()[driven].sum() / section)
    return TwinRun(mode, np.array(strain), np.array(stress), m.dissipated, cells,
                   length / cells[0])


def judge(spheres_strain, spheres_stress, fe, volume):
    """The twin's figures against the spheres' curve (signed as recorded)."""
    sign = 1.0 if fe.mode == "tension" else -1.0
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


def twin(spec, record, rate_speedup=RATE_SPEEDUP):
    """Both specimens of the scale's record with the slab's FE law (spec: a SlabSpec with
    fe_material 'damage'). Returns {mode: (TwinRun, figures)}."""
    from cases.slab.geometry import slab_grid
    from cases.slab.scales import SLAB
    from fenicsx_side.damage_law import ConcreteDamage
    law = ConcreteDamage(**spec.damage_law())
    grid = slab_grid(spec)
    size = tuple(record["size"])
    nz = max(1, round(size[2] / (SLAB[2] / grid.n[2])))
    loading = record["loading"]
    volume = float(np.prod(size))
    out = {}
    for mode, rate in (("compression", loading["strain_rate"]),
                       ("tension", loading["tension_rate"])):
        curve = record["curves"][mode]
        end = abs(curve["strain"][-1])
        fe = run_specimen(law, spec.density, size, grid.h, nz, mode, rate * rate_speedup,
                          end * 1.02)
        out[mode] = (fe, judge(curve["strain"], curve["stress"], fe, volume))
    return out


def plot(path, record, result, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from common.files import save_figure
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    for ax, mode in zip(axes, ("compression", "tension")):
        sign = 1.0 if mode == "tension" else -1.0
        curve = record["curves"][mode]
        fe, fig_ = result[mode]
        ax.plot(sign * 1e3 * np.asarray(curve["strain"]), sign * 1e-6 * np.asarray(
            curve["stress"]), "k", label="spheres (CPM)")
        ax.plot(sign * 1e3 * fe.strain, sign * 1e-6 * fe.stress, "C3",
                label=f"FE, {fe.cells[0]}×{fe.cells[1]}×{fe.cells[2]} cells")
        ax.set_xlabel(f"{'extension' if sign > 0 else 'shortening'} strain (‰)")
        ax.set_ylabel(f"{mode} stress (MPa)")
        ax.set_title(f"{mode}: nRMS to peak {fig_['nrms_to_peak']:.2f}, work ratio "
                     f"{fig_['work_ratio']:.2f}", fontsize=9)
        ax.legend(fontsize=8)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)
