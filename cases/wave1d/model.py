"""One coupled run of the 1D model: a YADE chain coupled to a dolfinx bar through the builder."""
import math
from dataclasses import asdict, dataclass
from time import perf_counter

import numpy as np

from cases.wave1d.energy import lattice_energy, weighted_invariant
from cases.wave1d.spec import E, RHO, Layout


@dataclass
class Wave1DResult:
    incident: tuple          # (low, high) energies, J
    reflected: tuple
    transmitted: tuple
    overlap: float           # weighted energy left in the bridging domain at t_reflected
    coupling_work: float     # net work of the multipliers (0 when the constraints hold)
    max_gap: float           # largest |d − k u| over bridging spheres and steps, m
    dt: float
    steps: int
    n_bridging: int
    seconds: float
    x_de: np.ndarray         # DE-zone sphere positions and their displacement at t_reflected
    u_de: np.ndarray
    u_de_incident: np.ndarray  # ... and at t_incident
    x_fe: np.ndarray         # bar stations and their displacement at t_reflected
    u_fe: np.ndarray


class ChainScene:
    """The chain of the 1D model as a DE scene (orchestrator.contracts.DEScene); its last
    sphere is the driven end, moved kinematically."""
    time_step = (None, "")

    def __init__(self, lay):
        self.lay = lay

    def place(self, keep):
        from yade_side.chain import build_chain
        from yade_side.scene import reset_scene
        reset_scene()
        lay = self.lay
        self.ids = build_chain((lay.x0_chain, 0, 0), lay.L, lay.n_spheres, E, RHO, lay.area)
        return self.ids

    def critical_dt(self, beta):
        return chain_critical_dt(self.lay, beta)

    def start(self, dt):
        from yade_side.scene import block_dofs, cpm_engines, create_cohesive_links
        cpm_engines(dt=dt)
        create_cohesive_links()
        block_dofs(self.ids[-1:], "xyzXYZ")  # moved kinematically: Newton keeps its velocity
        return True

    def attach(self, couple):
        return False


def run(spec):
    """One coupled run of `spec`: energies and the reflected-wave snapshot."""
    from orchestrator.builder import CouplingSpec, Description, assemble
    from orchestrator.coupling.bridging import Bridging, HalfSpaceZone
    start = perf_counter()
    lay = Layout(spec)
    bridging = Bridging(HalfSpaceZone((lay.x_b, 0, 0), (-1, 0, 0)), spec.layers, lay.h)
    coupling = CouplingSpec(spec.variant, spec.relaxation, rotations=False,
                            weighting=spec.weighting)
    parts = assemble(Description(ChainScene(lay), lambda w: bar_model(lay.n_fe, lay.h, w),
                                 bridging, coupling, dt_safety=spec.dt_safety,
                                 band_tol=1e-9 * lay.h))
    snaps, max_gap, n_inc, n_ref = _march(parts, lay, spec)
    energies = _energies(snaps, parts, bridging, lay, spec, n_inc, n_ref)
    x_chain, de_zone = snaps["x_chain"], snaps["de_zone"]
    return Wave1DResult(*energies, parts.stepper.exchange.net, max_gap, parts.dt, n_ref + 1,
                        len(parts.bridge_index), perf_counter() - start, x_chain[de_zone],
                        snaps[n_ref][0][de_zone], snaps[n_inc][0][de_zone],
                        lay.h * np.arange(snaps["n_stations"]), snaps[n_ref][1])


def _march(parts, lay, spec):
    """Drive the chain's end and step to just after the reflected instant; snapshots of the
    chain's and the bar's displacements at the incident and reflected instants (and the
    steps after them, for the leap-frog invariants)."""
    from yade_side.bulk import BodySet
    O, fe, dt, stepper = parts.O, parts.fe, parts.dt, parts.stepper
    chain = BodySet(parts.ids)
    x_chain = chain.ref_pos[:, 0]
    n_inc, n_ref = (math.ceil(t / dt) for t in (lay.t_incident, lay.t_reflected))
    lf, hf = lay.drive(dt * np.arange(n_ref + 2))
    drive_vel = np.diff(spec.lf_amplitude * lf + spec.hf_amplitude * hf) / dt
    station, n_stations = bar_stations(fe, lay.h)
    driver = O.bodies[int(parts.ids[-1])]
    snaps = {"x_chain": x_chain, "de_zone": x_chain > lay.x_b + 1e-9 * lay.h,
             "station": station, "n_stations": n_stations}

    def snapshot(n):
        snaps[n] = (chain.read()[:, 0] - x_chain,
                    np.bincount(station, fe.u[0::3]) / np.bincount(station))

    def de_step():
        driver.state.vel = (drive_vel[step], 0.0, 0.0)
        O.step()

    stepper.de_step = de_step
    max_gap = 0.0
    for step in range(n_ref + 1):
        if step in (n_inc, n_inc + 1, n_ref, n_ref + 1):
            snapshot(step)
        c = stepper.step()
        max_gap = max(max_gap, float(np.abs(c.q - c.Gu).max()))
    snapshot(n_ref + 1)
    return snaps, max_gap, n_inc, n_ref


def _energies(snaps, parts, bridging, lay, spec, n_inc, n_ref):
    """(incident, reflected, transmitted, overlap) energies of the run's snapshots."""
    dt, fe, de_zone, station = parts.dt, parts.fe, snaps["de_zone"], snaps["station"]
    consistent = spec.weighting == "consistent"
    fe_only = np.arange(snaps["n_stations"]) <= lay.n_fe - spec.layers
    m_de, k_de = RHO * lay.area * lay.L, E * lay.area / lay.L
    m_fe, k_fe = RHO * lay.area * lay.h, E * lay.area / lay.h

    def de_energy(n):
        return lattice_energy(snaps[n][0][de_zone], snaps[n + 1][0][de_zone], dt, m_de, k_de,
                              lay.omega_split)

    transmitted = lattice_energy(snaps[n_ref][1][fe_only], snaps[n_ref + 1][1][fe_only], dt,
                                 m_fe, k_fe, lay.omega_split)
    # what stays in the overlap, weighted as the bridging Hamiltonian: the points and links
    # that the DE-zone and FE-only energies leave out
    # (consistent weighting: the bar's masses are α-weighted already)
    x_fe = lay.h * np.arange(snaps["n_stations"])
    station_weight = (lambda x: np.ones(len(x))) if consistent else bridging.alpha
    overlap = (weighted_invariant(snaps[n_ref][0], snaps[n_ref + 1][0], dt, m_de, k_de,
                                  snaps["x_chain"], ~de_zone, np.flatnonzero(~de_zone),
                                  bridging.beta)
               + weighted_invariant(snaps[n_ref][1], snaps[n_ref + 1][1], dt,
                                    np.bincount(station, fe.mass[0::3]), k_fe, x_fe, ~fe_only,
                                    np.arange(lay.n_fe - spec.layers, lay.n_fe), bridging.alpha,
                                    station_weight))
    return de_energy(n_inc), de_energy(n_ref), transmitted, overlap


def bar_model(n_elements, h, weight=None):
    """The FE bar on [0, n h] × [−h/2, h/2]²: hexahedra, one across, ν = 0, y and z held;
    `weight(x)`: ElasticModel's energy weight (α of the consistent weighting)."""
    from fenicsx_side.mesh import box_mesh
    from fenicsx_side.model import ElasticModel
    msh = box_mesh((0, -h / 2, -h / 2), (n_elements * h, h / 2, h / 2), (n_elements, 1, 1))
    return ElasticModel(msh, E, 0.0, RHO, weight=weight,
                        dirichlet=[(lambda x: np.full(x.shape[1], True), (1, 2))])


def chain_critical_dt(lay, beta):
    """2/ω_max of the chain whose sphere masses are β ρAL and links k = EA/L × the mean β of
    their two spheres (yade_side.weighting; β = 1: the plain chain, L/c up to the end effect)."""
    from scipy.linalg import eigvalsh_tridiagonal
    m = beta * RHO * lay.area * lay.L
    k = 0.5 * (beta[:-1] + beta[1:]) * E * lay.area / lay.L
    diag = (np.r_[k, 0.0] + np.r_[0.0, k]) / m
    lam = eigvalsh_tridiagonal(diag, -k / np.sqrt(m[:-1] * m[1:]), select="i",
                               select_range=(len(m) - 1, len(m) - 1))[0]
    return 2.0 / math.sqrt(lam)


def bar_stations(fe, h):
    """(station of each node, number of stations): nodes grouped by their x = i h."""
    station = np.rint(fe.nodes[:, 0] / h).astype(int)
    return station, station.max() + 1


def summarise(spec, result, reference):
    """summary.json content: the issue's keys, the split energies, the parameters."""
    incident, reflected = sum(result.incident), sum(result.reflected)
    ref_reflected = sum(reference.reflected)
    lf, ref_lf = result.transmitted[0], reference.transmitted[0]
    lay = Layout(spec)
    return {
        "incident_energy": incident,
        "reflected_energy": reflected,
        "reference_reflected_energy": ref_reflected,
        "attenuation_percent": 100.0 * (1.0 - reflected / ref_reflected),
        "transmitted_low_frequency_energy": lf,
        "reference_transmitted_low_frequency_energy": ref_lf,
        "low_frequency_transmission_change_percent": 100.0 * (lf / ref_lf - 1.0),
        "incident_low_frequency_energy": result.incident[0],
        "incident_high_frequency_energy": result.incident[1],
        "reflected_low_frequency_energy": result.reflected[0],
        "reflected_high_frequency_energy": result.reflected[1],
        "transmitted_high_frequency_energy": result.transmitted[1],
        "overlap_energy": result.overlap,
        "energy_balance_residual": (incident - reflected - sum(result.transmitted)
                                    - result.overlap),
        "coupling_net_work": result.coupling_work,
        "max_constraint_gap": result.max_gap,
        "parameters": {**asdict(spec), "time_step": result.dt, "steps": result.steps,
                       "bridging_spheres": result.n_bridging, "spheres": lay.n_spheres,
                       "fe_elements": lay.n_fe, "sphere_spacing": lay.L,
                       "hf_angular_frequency": lay.omega_hf, "split_angular_frequency":
                       lay.omega_split, "t_incident": lay.t_incident,
                       "t_reflected": lay.t_reflected},
        "seconds": result.seconds + reference.seconds,
    }


def run_to_folder(spec, out):
    """Run `spec` and its full-Lagrange reference; write summary.json and wave.png into the
    folder `out` (made already). Returns the summary."""
    from cases.wave1d.plots import plot_wave
    from common.files import write_json
    reference = run(spec.reference())
    result = reference if spec == spec.reference() else run(spec)
    summary = summarise(spec, result, reference)
    write_json(out / "summary.json", summary)
    plot_wave(out / "wave.png", spec, result, reference)
    return summary


def result_line(spec, summary, out):
    """The one line a wave1d run prints."""
    return (f"wave1d {spec.variant}, r = {spec.relaxation:g}, n_b = {spec.layers}, ratio "
            f"{spec.ratio}: attenuation {summary['attenuation_percent']:.2f} %, LF transmission "
            f"change {summary['low_frequency_transmission_change_percent']:+.3f} %; results in "
            f"{out}")
