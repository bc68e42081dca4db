"""The 1D spurious-reflection study of the paper's §4 (Figs. 4–7).

Model along x: a coarse FE bar (the project's dolfinx partner: hexahedra with one element
across the section, ν = 0, y and z held, i.e. a lumped 1D bar) on [0, x_b]; a fine chain of
YADE spheres (yade_side.chain, same long-wave speed and impedance) from x_b − n_b h to the
driven end; the overlap [x_b − n_b h, x_b] is the bridging domain of n_b elements. The free
end of the chain is driven in displacement by a low-frequency pulse (carried by both models)
plus a high-frequency one (beyond the FE cut-off, so the coupling reflects it).

Energies are leap-frog invariants of regions of the two models at two instants (see
`Layout`): the incident wave, wholly in the DE zone before it reaches the bridging domain;
the reflected wave, back in the DE zone before it reaches the driven end; the transmitted
wave, in the FE-only part of the bar. Each is split into low and high frequencies by a
discrete Fourier transform over its region (Parseval, exact for a uniform lattice), at
ω_split = c/h: half the bar's cut-off 2c/h, where the lumped bar's phase error is ~5 %.
"""
import csv
import math
from dataclasses import asdict, astuple, dataclass, replace
from time import perf_counter

import numpy as np

from orchestrator.bridging import check_weighting

E, RHO = 30e9, 2400.0          # concrete-like bar (m, kg, s)
C = math.sqrt(E / RHO)
LF_ELEMENTS = 20               # LF pulse sin²(πt/T), c T = 20 h: wavelengths >= 10 h
HF_BANDWIDTH = 0.08            # relative spectral std of the Gaussian HF wave packet
HF_CUT = 4.0                   # HF packet cut at ±4 standard deviations (e^-8 of the peak)
MARGIN_ELEMENTS = 6            # clearance kept between waves and region edges, in h


def auto_relaxation(ratio, layers, variant="diagonal", dt_safety=0.8):
    """Default r: a fit of the measured best r of this model (docs/wave1d.md).

    Relaxation acts per time step (each correction removes a fraction ~1/r of the gap), so
    the best r grows as the step shrinks, measured ∝ (Δt)^-3/2; it grows slowly with the
    ratio (the HF packet sits higher, √ratio × the bar's cut-off) and with n_b up to 4
    layers; the full solver needs about twice the diagonal's r.
    """
    r = (2.0 + 0.5 * ratio) * math.sqrt(min(layers, 4) / 3.0) * (0.8 / dt_safety) ** 1.5
    return round(2.0 * r if variant == "full" else r, 2)


@dataclass
class Wave1DSpec:
    variant: str = "diagonal"        # multiplier solver: full | diagonal
    relaxation: object = "auto"      # r >= 1, or "auto"
    layers: int = 3                  # n_b, bridging FE layers
    ratio: int = 5                   # FE element length / sphere spacing
    element: float = 0.05            # FE element length h (m); section h × h
    dt_safety: float = 0.8           # × the smaller critical step
    weighting: str = "nodal"         # bridging weights: "nodal" (the paper's) or "consistent"
    lf_amplitude: float = 1e-6       # m
    hf_amplitude: float = 2e-7       # m

    def __post_init__(self):
        if self.variant not in ("full", "diagonal"):
            raise ValueError(f"wave1d: variant must be 'full' or 'diagonal', got {self.variant!r}")
        if int(self.layers) != self.layers or self.layers < 1:
            raise ValueError(f"wave1d: layers must be an integer >= 1, got {self.layers!r}")
        if int(self.ratio) != self.ratio or self.ratio < 2:
            raise ValueError(f"wave1d: ratio must be an integer >= 2 (whole spheres per "
                             f"element, and room between the FE and DE cut-offs), got {self.ratio!r}")
        self.layers, self.ratio = int(self.layers), int(self.ratio)
        if not self.element > 0:
            raise ValueError(f"wave1d: element must be > 0, got {self.element!r}")
        for name in ("lf_amplitude", "hf_amplitude"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"wave1d: {name} must be >= 0, got {getattr(self, name)!r}")
        if self.lf_amplitude + self.hf_amplitude == 0:
            raise ValueError("wave1d: lf_amplitude and hf_amplitude are both 0: no wave")
        check_weighting("wave1d", self.weighting)
        if not 0 < self.dt_safety <= 1:
            raise ValueError(f"wave1d: dt_safety must be in (0, 1], got {self.dt_safety!r}")
        if self.relaxation == "auto":
            self.relaxation = auto_relaxation(self.ratio, self.layers, self.variant,
                                              self.dt_safety)
        try:
            self.relaxation = float(self.relaxation)
        except (TypeError, ValueError):
            raise ValueError(f"wave1d: relaxation must be a number >= 1 or 'auto', "
                             f"got {self.relaxation!r}") from None
        if not self.relaxation >= 1:
            raise ValueError(f"wave1d: relaxation must be >= 1, got {self.relaxation!r}")

    def reference(self):
        """Full Lagrange, r = 1, same geometry and excitation."""
        return replace(self, variant="full", relaxation=1.0)


class Layout:
    """Geometry, excitation and measuring instants derived from a spec (times in s).

    HF packet: carrier ω_hf = √(ω_fe ω_de), the geometric mean of the bar's cut-off 2c/h and
    the chain's 2c/L, so it sits as far as possible from both; it travels at the chain's group
    velocity v_g. Both pulses start at t = 0. The DE zone is long enough that (1) both pulses
    have left the driven end before the faster one (LF, speed c) reaches the bridging domain
    (incident instant), and (2) the reflected HF packet, which may turn anywhere in the
    bridging domain, is back in the DE zone before its head reaches the driven end
    (reflected instant, when the packet's centre is half way back).
    """

    def __init__(self, spec):
        h = spec.element
        self.h, self.L = h, h / spec.ratio
        self.area = h * h
        self.omega_split = C / h
        self.omega_hf = 2 * C / math.sqrt(h * self.L)
        kappa = 2 * math.asin(self.omega_hf * self.L / (2 * C)) / self.L
        self.v_group = C * math.cos(kappa * self.L / 2)
        self.T_lf = LF_ELEMENTS * h / C
        self.tau = 1.0 / (HF_BANDWIDTH * self.omega_hf)
        self.T_hf = 2 * HF_CUT * self.tau
        nb = spec.layers * h
        margin = MARGIN_ELEMENTS * h
        hf_length = self.v_group * self.T_hf
        de = max(C * max(self.T_lf, self.T_hf) + margin,          # (1)
                 hf_length + 2 * nb + 2 * margin)                  # (2)
        self.n_de = math.ceil(de / self.L)        # sphere spacings in the DE zone
        self.de_length = self.n_de * self.L
        self.t_incident = max(self.T_lf, self.T_hf) + 0.5 * margin / C
        self.t_reflected = 0.5 * self.T_hf + 1.5 * self.de_length / self.v_group
        # transmitted LF: its tail must have left the bridging domain, its head not hit x = 0
        tail = C * (self.t_reflected - self.T_lf) - self.de_length - nb
        if tail < margin:
            self.t_reflected += (margin - tail) / C
        head = C * self.t_reflected - self.de_length - nb
        self.n_fe = spec.layers + math.ceil((head + margin) / h)
        self.x_b = self.n_fe * h                  # DE-zone / bridging interface
        self.x0_chain = self.x_b - nb
        self.n_spheres = spec.layers * spec.ratio + self.n_de + 1

    def drive(self, t):
        """Displacement imposed at the chain's free end: LF sin² pulse + Gaussian HF packet."""
        t = np.asarray(t, float)
        lf = np.where((t > 0) & (t < self.T_lf), np.sin(np.pi * t / self.T_lf) ** 2, 0.0)
        s = t - 0.5 * self.T_hf
        hf = np.where(np.abs(s) < 0.5 * self.T_hf,
                      np.exp(-0.5 * (s / self.tau) ** 2) * np.sin(self.omega_hf * s), 0.0)
        return lf, hf


def lattice_energy(d0, d1, dt, mass, stiffness, omega_split):
    """Leap-frog invariant ½ m v² + ½ k Δd₀ Δd₁ (v = (d1 − d0)/Δt) of a uniform lattice
    segment, split at ω_split by its discrete Fourier modes (periodic wrap: the segment must
    be at rest near both ends). Returns (low, high)."""
    n = len(d0)
    v = np.fft.rfft((d1 - d0) / dt)
    f0, f1 = np.fft.rfft(d0), np.fft.rfft(d1)
    kappa_s = 2 * np.pi * np.arange(len(v)) / n         # κ × spacing
    w = np.full(len(v), 2.0)                            # rfft: each interior mode counts twice
    w[0] = 1.0
    if n % 2 == 0:
        w[-1] = 1.0
    spring = 4 * np.sin(kappa_s / 2) ** 2               # |e^{iκs} − 1|²
    e = 0.5 * w / n * (mass * np.abs(v) ** 2 + stiffness * spring * (f0 * np.conj(f1)).real)
    low = 2 * math.sqrt(stiffness / mass) * np.sin(kappa_s / 2) < omega_split
    return float(e[low].sum()), float(e[~low].sum())


def weighted_invariant(d0, d1, dt, mass, stiffness, x, points, links, weight,
                       point_weight=None):
    """Leap-frog invariant Σ w ½ m v² over `points` (mask) + Σ w ½ k Δd₀ Δd₁ over `links`
    (index i: the link of points i, i+1) of a lattice at positions x along the axis, with
    the bridging weight w(x) (α or β) at the links' midpoints and `point_weight(x)` (default
    the same) at the points."""
    on_axis = lambda xs: np.column_stack([xs, np.zeros_like(xs), np.zeros_like(xs)])
    point_weight = weight if point_weight is None else point_weight
    v = (d1[points] - d0[points]) / dt
    kinetic = np.sum(point_weight(on_axis(x[points])) * np.broadcast_to(mass, x.shape)[points]
                     * v * v)
    w_links = weight(on_axis(0.5 * (x[links] + x[links + 1])))
    strain = np.sum(w_links * (d0[links + 1] - d0[links]) * (d1[links + 1] - d1[links]))
    return float(0.5 * kinetic + 0.5 * stiffness * strain)


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


def run(spec):
    """One coupled run of `spec`: energies and the reflected-wave snapshot."""
    from yade_side.weighting import weight_spheres
    from orchestrator.assembly import bridging_spheres, common_time_step
    from orchestrator.bridging import Bridging, HalfSpaceZone
    from orchestrator.coupling import Coupling
    from orchestrator.timeloop import CoupledStepper
    from yade_side import import_yade
    from yade_side.bulk import BodySet
    from yade_side.chain import build_chain
    from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene

    start = perf_counter()
    lay = Layout(spec)
    O = import_yade().Omega()
    reset_scene()
    ids = build_chain((lay.x0_chain, 0, 0), lay.L, lay.n_spheres, E, RHO, lay.area)
    bridging = Bridging(HalfSpaceZone((lay.x_b, 0, 0), (-1, 0, 0)), spec.layers, lay.h)
    consistent = spec.weighting == "consistent"
    fe = bar_model(lay.n_fe, lay.h, weight=bridging.alpha if consistent else None)
    x = lay.x0_chain + lay.L * np.arange(lay.n_spheres)
    beta = bridging.beta(np.column_stack([x, np.zeros((lay.n_spheres, 2))]))
    de_critical = chain_critical_dt(lay, beta if consistent else np.ones_like(beta))
    dt = common_time_step(spec.dt_safety, de_critical, fe.critical_dt())
    cpm_engines(dt=dt)
    create_cohesive_links()
    if consistent:
        weight_spheres(ids, beta)
    driver = O.bodies[int(ids[-1])]
    driver.state.blockedDOFs = "xyzXYZ"  # moved kinematically: Newton keeps its velocity

    chain = BodySet(ids)
    x_chain = chain.ref_pos[:, 0]
    index = bridging_spheres(bridging, chain.ref_pos, tol=1e-9 * lay.h)
    bridge = BodySet(ids[index])
    # the nodal weighting applies β and α in the coupling; the consistent one has them in
    # the partners' masses and stiffnesses already
    de_weight = np.ones(len(index)) if consistent else beta[index]
    fe_weight = np.ones(fe.ndof) if consistent else np.repeat(bridging.alpha(fe.nodes), 3)
    k, _ = fe.point_operators(bridge.ref_pos)
    coupling = Coupling(k, None, bridge.mass, bridge.inertia, de_weight, fe.mass, fe_weight,
                        fe.fixed, dt, variant=spec.variant, relaxation=spec.relaxation,
                        rotations=False)
    stepper = CoupledStepper(None, bridge, fe, coupling)

    n_inc, n_ref = (math.ceil(t / dt) for t in (lay.t_incident, lay.t_reflected))
    lf, hf = lay.drive(dt * np.arange(n_ref + 2))
    drive_vel = np.diff(spec.lf_amplitude * lf + spec.hf_amplitude * hf) / dt
    station, n_stations = bar_stations(fe, lay.h)
    de_zone = x_chain > lay.x_b + 1e-9 * lay.h
    fe_only = np.arange(n_stations) <= lay.n_fe - spec.layers
    snaps = {}

    def de_step():
        driver.state.vel = (drive_vel[step], 0.0, 0.0)
        O.step()

    stepper.de_step = de_step
    max_gap = 0.0
    for step in range(n_ref + 1):
        if step in (n_inc, n_inc + 1, n_ref, n_ref + 1):
            u_st = np.bincount(station, fe.u[0::3]) / np.bincount(station)
            snaps[step] = (chain.read()[:, 0] - x_chain, u_st)
        c = stepper.step()
        max_gap = max(max_gap, float(np.abs(c.q - c.Gu).max()))
    u_st = np.bincount(station, fe.u[0::3]) / np.bincount(station)
    snaps[n_ref + 1] = (chain.read()[:, 0] - x_chain, u_st)

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
    x_fe = lay.h * np.arange(n_stations)
    station_weight = (lambda x: np.ones(len(x))) if consistent else bridging.alpha
    overlap = (weighted_invariant(snaps[n_ref][0], snaps[n_ref + 1][0], dt, m_de, k_de, x_chain,
                                  ~de_zone, np.flatnonzero(~de_zone), bridging.beta)
               + weighted_invariant(snaps[n_ref][1], snaps[n_ref + 1][1], dt,
                                    np.bincount(station, fe.mass[0::3]), k_fe, x_fe, ~fe_only,
                                    np.arange(lay.n_fe - spec.layers, lay.n_fe), bridging.alpha,
                                    station_weight))
    return Wave1DResult(de_energy(n_inc), de_energy(n_ref), transmitted, overlap,
                        stepper.exchange.net, max_gap, dt, n_ref + 1, len(bridge),
                        perf_counter() - start, x_chain[de_zone], snaps[n_ref][0][de_zone],
                        snaps[n_inc][0][de_zone], x_fe, snaps[n_ref][1])


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
    their two spheres (weight_spheres; β = 1: the plain chain, L/c up to the end effect)."""
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


def plot_wave(path, spec, result, reference):
    """Displacement along the model at the reflected instant, variant over reference."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    lay = Layout(spec)
    fig, ax = plt.subplots(figsize=(9, 3.5))
    for res, style, label in ((reference, "-", "full Lagrange, r = 1"),
                              (result, "-", f"{spec.variant}, r = {spec.relaxation:g}")):
        line, = ax.plot(res.x_de, res.u_de * 1e6, style, lw=0.8, label=f"DE: {label}")
        ax.plot(res.x_fe, res.u_fe * 1e6, "--", color=line.get_color(), lw=0.8)
    ax.axvspan(lay.x0_chain, lay.x_b, color="0.9", label=f"bridging, n_b = {spec.layers}")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("displacement (µm)")
    ax.set_title(f"t = {lay.t_reflected * 1e3:.3f} ms: transmitted LF (FE, dashed), "
                 f"reflected wave (DE); ratio {spec.ratio}")
    ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, path)


def _save(fig, path):
    """PNG written atomically."""
    import io
    import matplotlib.pyplot as plt
    from orchestrator.results import write_atomic
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
    write_atomic(path, buf.getvalue(), mode="wb")


# --- the study (paper Figs. 4-7, and the automatic r) ---------------------------------------
STUDY_LAYERS = (1, 2, 3, 4, 5, 6)
STUDY_RELAXATIONS = tuple(np.round(np.logspace(0, 2, 13), 3))   # 1 … 100, 6 per decade
AUTO_RATIOS = (2, 3, 4, 5, 6, 7, 8)
CSV_FIELDS = ("study", "variant", "solver", "relaxation", "layers", "ratio", "dt_safety",
              "weighting",
              "attenuation_percent", "low_frequency_transmission_change_percent",
              "incident_energy", "reflected_energy", "reflected_low_frequency_energy",
              "reflected_high_frequency_energy", "transmitted_low_frequency_energy",
              "transmitted_high_frequency_energy", "coupling_net_work", "seconds")


def study_cases(layers=STUDY_LAYERS, relaxations=STUDY_RELAXATIONS, ratios=AUTO_RATIOS,
                ratio=5, **options):
    """(study, variant, spec) of the sweep: the four variants at `ratio` over n_b and r, and
    the automatic r (both solvers) at n_b = 3 for every ratio. `options`: other Wave1DSpec
    fields (dt_safety, weighting)."""
    for nb in layers:
        for solver in ("full", "diagonal"):
            yield "variants", solver, Wave1DSpec(solver, 1.0, nb, ratio, **options)
            for r in relaxations:
                if r > 1:
                    yield "variants", f"{solver}+relaxation", Wave1DSpec(solver, r, nb, ratio,
                                                                          **options)
    for q in ratios:
        for solver in ("full", "diagonal"):
            yield "auto", f"{solver}+relaxation", Wave1DSpec(solver, "auto", 3, q, **options)


def run_study(out, cases, quiet=False):
    """Run `cases` (from study_cases), one reference per geometry; write study.csv, the
    figures and table.md into `out`. Returns the rows."""
    from orchestrator.progress import progress
    from orchestrator.results import write_atomic
    cases = list(cases)
    references, rows, shapes = {}, [], {}
    with progress(len(cases), "wave1d-study", quiet) as bar:
        for study, variant, spec in cases:
            ref_spec = spec.reference()
            key = astuple(ref_spec)
            if key not in references:
                references[key] = run(ref_spec)
            ref = references[key]
            res = ref if spec == ref_spec else run(spec)
            s = summarise(spec, res, ref)
            rows.append({"study": study, "variant": variant, "solver": spec.variant,
                         "relaxation": spec.relaxation, "layers": spec.layers,
                         "ratio": spec.ratio, "dt_safety": spec.dt_safety,
                         "weighting": spec.weighting,
                         **{k: s[k] for k in CSV_FIELDS if k in s}})
            if spec.layers == 3 and spec.ratio == 5:
                shapes[(variant, spec.relaxation)] = res
                shapes[("full", 1.0)] = ref
            bar.update()
    text = _csv_text(rows)
    write_atomic(out / "study.csv", text)
    write_atomic(out / "table.md", markdown_table(rows))
    plot_study(out, rows, shapes)
    return rows


def _csv_text(rows):
    import io
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=CSV_FIELDS, lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    return buf.getvalue()


def best(rows, variant, layers, ratio=5):
    """Row of highest attenuation of `variant` at (layers, ratio) in the variants study."""
    cand = [r for r in rows if r["study"] == "variants" and r["variant"] == variant
            and r["layers"] == layers and r["ratio"] == ratio]
    return max(cand, key=lambda r: r["attenuation_percent"]) if cand else None


def markdown_table(rows):
    """The docs' tables: per n_b, diagonal alone and the best r of each relaxed variant
    (ratio 5), the 25–35 band of the paper; then the automatic r over the ratios."""
    lines = ["| n_b | diagonal r=1: att. % (LF %) | full+relax: best r, att. % (LF %) | "
             "diag+relax: best r, att. % (LF %) | diag+relax r in 25-35: att. % (LF %) | "
             "diag+relax: r with >= 80 % | r with >= 99 % |",
             "|---|---|---|---|---|---|---|"]
    for nb in sorted({r["layers"] for r in rows if r["study"] == "variants"}):
        diag = [r for r in rows if r["study"] == "variants" and r["variant"] == "diagonal"
                and r["layers"] == nb]
        cells = [f"{nb}", _fmt(diag[0]) if diag else "-"]
        for v in ("full+relaxation", "diagonal+relaxation"):
            b = best(rows, v, nb)
            cells.append(f"{b['relaxation']:g}: {_fmt(b)}" if b else "-")
        band = [r for r in rows if r["study"] == "variants" and r["variant"] ==
                "diagonal+relaxation" and r["layers"] == nb and 25 <= r["relaxation"] <= 35]
        cells.append(", ".join(f"r={r['relaxation']:g}: {_fmt(r)}" for r in band) or "-")
        relaxed = [r for r in rows if r["study"] == "variants" and r["layers"] == nb
                   and r["variant"] in ("diagonal", "diagonal+relaxation")]
        for level in (80, 99):
            ok = sorted(r["relaxation"] for r in relaxed if r["attenuation_percent"] >= level)
            cells.append(f"{ok[0]:g} – {ok[-1]:g} ({len(ok)} of {len(relaxed)})" if ok else "none")
        lines.append("| " + " | ".join(cells) + " |")
    auto = [r for r in rows if r["study"] == "auto"]
    if auto:
        lines += ["", "| ratio | auto r | variant | attenuation % | LF transmission change % |",
                  "|---|---|---|---|---|"]
        lines += [f"| {r['ratio']} | {r['relaxation']:g} | {r['variant']} | "
                  f"{r['attenuation_percent']:.2f} | "
                  f"{r['low_frequency_transmission_change_percent']:+.3f} |" for r in auto]
    return "\n".join(lines) + "\n"


def _fmt(row):
    return (f"{row['attenuation_percent']:.1f} "
            f"({row['low_frequency_transmission_change_percent']:+.2f})")


def plot_study(out, rows, shapes):
    """fig4 (diagonal vs n_b), fig5/fig6 (relaxed full/diagonal vs r per n_b), fig_lf (LF
    change vs r), fig7 (reflected wave shapes at n_b = 3, ratio 5), auto (r rule vs ratio)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    var = [r for r in rows if r["study"] == "variants"]
    if var:
        fig, ax = plt.subplots(figsize=(5, 3.5))
        d = sorted((r["layers"], r["attenuation_percent"]) for r in var
                   if r["variant"] == "diagonal")
        ax.plot(*zip(*d), "o-")
        ax.axhline(30, color="0.6", ls=":", label="paper: > 30 %")
        ax.set(xlabel="bridging layers n_b", ylabel="attenuation (%)",
               title="Fig. 4: diagonalised multipliers, r = 1")
        ax.legend()
        fig.tight_layout()
        _save(fig, out / "fig4_diagonal.png")
        for name, variant, title in (
                ("fig5_full_relaxation.png", "full+relaxation", "Fig. 5: full + relaxation"),
                ("fig6_diagonal_relaxation.png", "diagonal+relaxation",
                 "Fig. 6: diagonalised + relaxation")):
            base = "full" if variant.startswith("full") else "diagonal"
            fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
            for nb in sorted({r["layers"] for r in var}):
                pts = sorted((r["relaxation"], r["attenuation_percent"],
                              r["low_frequency_transmission_change_percent"]) for r in var
                             if r["layers"] == nb and r["variant"] in (variant, base))
                rr, att, lf = zip(*pts)
                axes[0].semilogx(rr, att, "o-", ms=3, label=f"n_b = {nb}")
                axes[1].semilogx(rr, lf, "o-", ms=3, label=f"n_b = {nb}")
            axes[0].axhline(99, color="0.6", ls=":")
            axes[0].set(xlabel="relaxation r", ylabel="attenuation (%)", title=title,
                        ylim=(min(0, axes[0].get_ylim()[0]), 100))
            axes[1].axhspan(-1, 1, color="0.9")
            axes[1].set(xlabel="relaxation r", ylabel="LF transmission change (%)",
                        title="low-frequency transmitted energy vs reference")
            axes[0].legend(fontsize=7)
            fig.tight_layout()
            _save(fig, out / name)
    picks = [("full", 1.0), ("diagonal", 1.0)]
    for v in ("full+relaxation", "diagonal+relaxation"):
        b = best(rows, v, 3)
        picks += [(v, b["relaxation"])] if b else []
        picks += [(v, r["relaxation"]) for r in rows
                  if r["study"] == "auto" and r["ratio"] == 5 and r["variant"] == v]
    picks = [k for k in dict.fromkeys(picks) if k in shapes]
    if picks:
        fig, axes = plt.subplots(len(picks), 1, figsize=(8, 1.3 * len(picks) + 0.8),
                                 sharex=True, sharey=True, squeeze=False)
        for ax, k in zip(axes[:, 0], picks):
            res = shapes[k]
            ax.plot(res.x_de, res.u_de * 1e9, lw=0.7)
            ax.set_title(f"{k[0]}, r = {k[1]:g}", fontsize=8, loc="left")
            ax.set_ylabel("nm", fontsize=7)
        axes[-1, 0].set_xlabel("x (m): DE zone at the reflected instant")
        fig.suptitle("Fig. 7: reflected (spurious) wave, n_b = 3, ratio 5", fontsize=9)
        fig.tight_layout()
        _save(fig, out / "fig7_reflected_waves.png")
    auto = [r for r in rows if r["study"] == "auto"]
    if auto:
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.5))
        for v in ("full+relaxation", "diagonal+relaxation"):
            pts = sorted((r["ratio"], r["attenuation_percent"],
                          r["low_frequency_transmission_change_percent"]) for r in auto
                         if r["variant"] == v)
            q, att, lf = zip(*pts)
            axes[0].plot(q, att, "o-", label=v)
            axes[1].plot(q, lf, "o-", label=v)
        axes[0].axhline(99, color="0.6", ls=":")
        axes[1].axhspan(-1, 1, color="0.9")
        axes[0].set(xlabel="discretisation ratio", ylabel="attenuation (%)",
                    title="automatic r, n_b = 3")
        axes[1].set(xlabel="discretisation ratio", ylabel="LF transmission change (%)")
        axes[0].legend(fontsize=7)
        fig.tight_layout()
        _save(fig, out / "auto_relaxation.png")
