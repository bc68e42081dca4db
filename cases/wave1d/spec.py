"""The 1D spurious-reflection model of the paper's §4: its description and layout.

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
import math
from dataclasses import dataclass, replace

import numpy as np

from orchestrator.casefile import (check_spec, choice, integer, integer_or_auto as layers_kind,
                                   number, number_or_auto, safety_range, spec_key as key, within)
from orchestrator.coupling.bridging import WEIGHTINGS
from orchestrator.coupling.correction import VARIANTS
from orchestrator.coupling.relaxation import MAX_LAYERS, auto_coupling, auto_relaxation, layers_for

MIN_LAYERS = 3      # layers 'auto' widens the band from this one (the paper's band)

E, RHO = 30e9, 2400.0          # concrete-like bar (m, kg, s)
C = math.sqrt(E / RHO)
LF_ELEMENTS = 20               # LF pulse sin²(πt/T), c T = 20 h: wavelengths >= 10 h
HF_BANDWIDTH = 0.08            # relative spectral std of the Gaussian HF wave packet
HF_CUT = 4.0                   # HF packet cut at ±4 standard deviations (e^-8 of the peak)
MARGIN_ELEMENTS = 6            # clearance kept between waves and region edges, in h


@dataclass
class Wave1DSpec:
    variant: str = key("diagonal", choice(*VARIANTS), section="coupling",
                       help="multiplier solver")
    relaxation: object = key("auto", number_or_auto, within(1, 1e6, low_open=False),
                             section="coupling",
                             help="relaxation r >= 1, or 'auto': the rule of docs/wave1d.md")
    layers: object = key("auto", layers_kind, within(1, 50, low_open=False), section="coupling",
                         help="bridging FE layers n_b, or 'auto': the rule's narrowest band "
                              "from 3 that meets the goal (with relaxation 'auto', r alone "
                              "first; with a given r, at that r)")
    ratio: int = key(5, integer, within(2, 100, low_open=False), section="wave1d",
                     help="FE element length / sphere spacing (>= 2: whole spheres per element, "
                          "and room between the FE and DE cut-offs)")
    element: float = key(0.05, number, within(0, 10, "m"), section="wave1d",
                         help="FE element length h (m); section h × h")
    dt_safety: float = key(0.8, number, safety_range, section="time",
                           help="time step / the smaller critical step")
    weighting: str = key("consistent", choice(*WEIGHTINGS), section="coupling",
                         help="bridging weights: 'consistent' or 'nodal' (the paper's)")
    lf_amplitude: float = key(1e-6, number, within(0, 1e-3, "m", low_open=False),
                              section="wave1d",
                              help="low-frequency pulse amplitude (m)")
    hf_amplitude: float = key(2e-7, number, within(0, 1e-3, "m", low_open=False),
                              section="wave1d",
                              help="high-frequency packet amplitude (m)")
    rule: str = None                 # set by "auto": why the rule took its r and n_b

    def __post_init__(self):
        check_spec(self, "wave1d")
        auto_layers = self.layers == "auto"
        if auto_layers:
            self.layers = MIN_LAYERS
        if self.lf_amplitude + self.hf_amplitude == 0:
            raise ValueError("wave1d: lf_amplitude and hf_amplitude are both 0: no wave")
        if auto_layers and self.relaxation == "auto":
            self.relaxation, self.layers, self.rule = auto_coupling(
                self.ratio, self.layers, self.variant, self.dt_safety, self.weighting)
        elif self.relaxation == "auto":
            self.relaxation = auto_relaxation(self.ratio, self.layers, self.variant,
                                              self.dt_safety, self.weighting)
            self.rule = f"r with the most margin to the goal at n_b = {self.layers}"
        self.relaxation = float(self.relaxation)
        if auto_layers and self.rule is None:
            nb, att, lf = layers_for(self.relaxation, self.ratio, self.variant, self.dt_safety,
                                     self.weighting, MIN_LAYERS)
            figures = f"predicted attenuation {100 * att:.2f} %, LF change {100 * lf:+.2f} %"
            self.layers = nb or MIN_LAYERS
            self.rule = (f"n_b = {nb}, the narrowest band where r = {self.relaxation:g} meets "
                         f"the goal ({figures})" if nb else
                         f"r = {self.relaxation:g} meets the goal at no n_b up to "
                         f"{MAX_LAYERS}: n_b = {MIN_LAYERS} kept ({figures})")

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
