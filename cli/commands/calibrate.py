"""`calibrate`: uniaxial compression and tension tests of a CPM packing, a tension test to full
separation for the fracture energy; fit of the CPM micro-parameters to target E, fc, Gf
(and ν); with --fe-twin, the slab's FE damage law on the same specimens against the scale's
calibration record (cases/slab/twin.py)."""
from cases.slab import SCALES
from cases.slab.scales import CONCRETES
from cli.commands._options import add_out, add_threads, ranged
from orchestrator.coupling.assembly import MIN_SAFETY

NAME = "calibrate"
HELP = ("uniaxial tests of a CPM packing (E, ν, fc, ft, Gf); fit CPM micro-parameters to "
        "target --young, --fc, --gf (--poisson)")


# the spheres' tests' options, their defaults (None: the help says), and those a mode ignores:
# given there, they are refused (one line), never recorded as if used
TESTS = {"young": 31e9, "fc": 31e6, "poisson": None, "density": 2400.0, "gf": None,
         "no_gf": False, "radius": None, "size": (0.56, 0.56, 0.28), "measure_only": False,
         "sigma_t": None, "cpm_young": None, "eps_crack_onset": None, "cpm_poisson": None,
         "rel_ductility": None, "shear_contrib": None, "strain_rate": 0.05, "dt_safety": 0.8,
         "shear_release": 0.0, "tol": 0.02, "gf_tol": 0.05, "max_iter": 6, "seed": 1}
FIT_ONLY = ("young", "poisson", "tol", "gf_tol", "max_iter")      # not with --measure-only
TWIN = {"gf": None, "no_bending": False, "concrete": "plain"}       # with --fe-twin


def configure(p):
    def add(name, help, **kw):
        default = {**TESTS, **TWIN}[name]
        shown = "" if default in (None, False) else f" (default {_shown(default)})"
        p.add_argument("--" + name.replace("_", "-"), default=None, help=help + shown, **kw)
    add("young", "target E (Pa)", type=ranged(1e6, 1e12))
    add("fc", "target compressive strength (Pa)", type=ranged(1e5, 1e9))
    add("poisson", "target ν (default: keep CpmMat.poisson and report ν)",
        type=ranged(0, 0.5, high_open=True))
    add("density", "bulk density (kg/m³)", type=ranged(100, 2e4, low_open=False))
    add("gf", "target fracture energy (J/m², default fib Model Code 2010: 73 fc^0.18 with fc "
              "in MPa); with --fe-twin, the FE's Gf where the record has none",
        type=ranged(0, 1e6))
    add("no_gf", "keep relDuctility: no separation test, ft from a tension test",
        action="store_true")
    size = p.add_mutually_exclusive_group()
    size.add_argument("--scale", choices=tuple(SCALES), default="small",
                      help="the slab's sphere radius of this scale (default small)")
    size.add_argument("--radius", type=ranged(0, 0.1), help="sphere radius (m)")
    add("size", "specimen (m), loaded along its length (the slab's thickness)",
        type=ranged(0, 10), nargs=3, metavar=("LENGTH", "WIDTH", "THICKNESS"))
    add("measure_only", "only measure the given micro-parameters, no fit", action="store_true")
    add("sigma_t", "initial CpmMat.sigmaT (Pa)", type=ranged(0, 1e9))
    add("cpm_young", "initial CpmMat.young (Pa)", type=ranged(0, 1e13))
    add("eps_crack_onset", "initial CpmMat.epsCrackOnset", type=ranged(0, 1, high_open=True))
    add("cpm_poisson", "initial CpmMat.poisson", type=ranged(0, 1))
    add("rel_ductility", "initial CpmMat.relDuctility", type=ranged(0, 1e4))
    add("shear_contrib", "CpmMat.equivStrainShearContrib ξ, kept by the fit (default 0: links "
                         "never break in shear)", type=ranged(0, 1, low_open=False))
    add("strain_rate", "compression strain rate (1/s; tension: 1/10 of it)",
        type=ranged(0, 100))
    add("dt_safety", "time step, × YADE's critical P-wave step",
        type=ranged(MIN_SAFETY, 1, low_open=False))
    add("shear_release", "period (s) at which links past ω = 0.9 lose their shear stiffness, "
                         "as in the slab (0: never); with a shorter step it closes the "
                         "separation test's energy balance (docs/calibration.md)",
        type=ranged(0, 1, low_open=False))
    add("tol", "relative tolerance on E and fc of the fit", type=ranged(0, 1, high_open=True))
    add("gf_tol", "relative tolerance on Gf of the fit", type=ranged(0, 1, high_open=True))
    add("max_iter", "fit iterations", type=ranged(1, 100, int, False))
    add("seed", "packing seed", type=ranged(0, 2**31 - 1, int, False))
    p.add_argument("--fe-twin", action="store_true",
                   help="run the slab's FE damage law of --scale on the specimens of the "
                        "scale's calibration record (its --concrete set; --gf gives the FE's Gf "
                        "where the record has none) and on a tension-compression cycle and a "
                        "bending strip to failure that the spheres run too, and compare the "
                        "curves (twin.json, twin.png)")
    add("no_bending", "with --fe-twin: leave out the bending strip (its spheres take ~4 min at "
                      "small scale, 9 at medium, over an hour at paper scale)",
        action="store_true")
    add("concrete", "with --fe-twin: the scale's CPM set whose record is compared",
        choices=CONCRETES)
    add_threads(p)
    add_out(p, "results folder")


def _shown(value):
    return " ".join(map(_shown, value)) if isinstance(value, tuple) else f"{value:g}" if \
        isinstance(value, float) else value


def _by_mode(args):
    """The options that act in args' mode, with their defaults filled in; one line (ValueError)
    for one given that its mode ignores."""
    given = {k for k in {**TESTS, **TWIN} if getattr(args, k) is not None
             and getattr(args, k) is not False}         # (0 is given)
    if args.fe_twin:
        ignored = sorted(given - set(TWIN), key=list(TESTS).index)
        if ignored:
            raise ValueError(f"--{ignored[0].replace('_', '-')} acts on the spheres' tests, "
                             f"not with --fe-twin (which runs the scale's calibration record)")
    else:
        twin_only = sorted(given & {"no_bending", "concrete"})
        if twin_only:
            raise ValueError(f"--{twin_only[0].replace('_', '-')} acts only with --fe-twin")
        if args.measure_only and given & set(FIT_ONLY):
            name = next(k for k in FIT_ONLY if k in given)
            raise ValueError(f"--{name.replace('_', '-')} acts on a fit, not with "
                             f"--measure-only")
    for name, default in {**TESTS, **TWIN}.items():
        if getattr(args, name) is None:
            setattr(args, name, default)
    return args


def run(args):
    from dataclasses import asdict, replace
    from orchestrator.run.folder import prepare_out
    from yade_side import calibration as cal, fit
    from yade_side.fracture import mc2010_fracture_energy
    from yade_side.material import ConcreteParams

    args = _by_mode(args)
    if args.fe_twin:
        return run_twin(args)
    # every input is checked before YADE is imported and the results folder made
    if args.no_gf and args.gf is not None:
        raise ValueError(f"--gf {args.gf!r} and --no-gf exclude each other")
    radius = args.radius if args.radius is not None else SCALES[args.scale].radius
    size = cal.check_specimen(radius, args.size)
    gf = None if args.no_gf else (args.gf if args.gf is not None
                                  else mc2010_fracture_energy(args.fc))
    target = fit.Target(young=args.young, compressive_strength=args.fc, poisson=args.poisson,
                        density=args.density, fracture_energy=gf)
    start = {k: v for k, v in dict(young=args.cpm_young, sigmaT=args.sigma_t,
                                   epsCrackOnset=args.eps_crack_onset,
                                   poisson=args.cpm_poisson,
                                   relDuctility=args.rel_ductility,
                                   equivStrainShearContrib=args.shear_contrib).items()
             if v is not None}
    params = replace(ConcreteParams(), density=args.density, **start)
    loading = cal.Loading(strain_rate=args.strain_rate, tension_rate=0.1 * args.strain_rate,
                          dt_safety=args.dt_safety, shear_release=args.shear_release)
    out = prepare_out(args.out, args.force)
    from yade_side import import_yade
    import_yade(args.threads)
    sample = cal.packed_sample(radius, size, seed=args.seed)
    print(f"specimen {size[0]} × {size[1]} × {size[2]} m, R = {radius} m: "
          f"{len(sample.radii)} spheres, packing fraction {sample.fraction:.3f}")
    if args.measure_only:
        c = cal.uniaxial_test(sample, params, "compression", loading)
        if gf is None:
            t = cal.uniaxial_test(sample, params, "tension", loading)
        else:
            from yade_side.fracture import separation_test
            t = separation_test(sample, params, loading)
        result = dict(params=asdict(params), compression=c, tension=t, iterations=[],
                      converged=None)
    else:
        result = fit.calibrate(sample, target, params, loading, tol=args.tol,
                               gf_tol=args.gf_tol, max_iter=args.max_iter)
    c, t = result["compression"], result["tension"]
    macro = cal.summary(c, t)
    _write(out, radius, size, sample, target, loading, result, macro)
    plot_curves(out / "stress_strain.png", c, t, macro, radius)
    _print_result(result, macro, out)
    return 0


def run_twin(args):
    """--fe-twin: the FE law on the record's specimens; one line and exit 2 for a scale with
    no record."""
    import json
    from cases.slab import twin
    from cases.slab.scales import CALIBRATIONS
    from cases.slab.spec import SlabSpec
    from common.files import write_json
    from orchestrator.run.folder import prepare_out
    path = CALIBRATIONS / f"{args.scale}-{args.concrete}.json"
    if not path.is_file():
        raise ValueError(f"--fe-twin: scale {args.scale!r} has no calibration record for "
                         f"concrete {args.concrete!r} ({path.name} is not in {CALIBRATIONS})")
    spec = SlabSpec(scale=args.scale, concrete=args.concrete, fe_material="damage",
                    fracture_energy=args.gf)
    record = json.loads(path.read_text())
    out = prepare_out(args.out, args.force)
    from yade_side import import_yade
    import_yade(args.threads)
    cycle = twin.spheres_cycle(record)
    bending = None
    if not args.no_bending:
        from cases.slab.bending import BEND_END, BEND_SPEED, bending_to_failure_de
        travel, force, spheres, seconds = bending_to_failure_de(spec, BEND_SPEED, BEND_END)
        bending = (travel, force)
        print(f"bending strip: {spheres} spheres, {seconds:.0f} s")
    result = twin.twin(spec, record, cycle, bending)
    law = spec.damage_law()
    table = {mode: dict(figures, cells=list(fe.cells), h=fe.h)
             for mode, (fe, figures) in result.items()}
    spheres = {k: cycle[k].tolist() if hasattr(cycle[k], "tolist") else cycle[k]
               for k in ("strain", "stress", "targets", "steps", "dt", "spheres", "seconds")}
    write_json(out / "twin.json", dict(
        scale=args.scale, concrete=args.concrete, record=path.name, law=law, specimens=table,
        spheres_cycle=spheres, spheres_bending=None if bending is None else dict(
            travel_m=bending[0].tolist(), force_N=bending[1].tolist())))
    title = (f"{args.scale} scale, {args.concrete} set: FE E {law['young'] / 1e9:.1f} GPa, "
             f"ft {law['tensile_strength'] / 1e6:.2f} MPa, fc "
             f"{law['compressive_strength'] / 1e6:.1f} MPa, Gf {law['fracture_energy']:.0f}, "
             f"Gc {law['compressive_fracture_energy']:.0f} J/m²")
    twin.plot(out / "twin.png", record, result, title, cycle, bending)
    print(title)
    print("specimen     cells  nRMS to peak  peak spheres / FE (MPa)  work spheres / FE (J)")
    for mode in ("compression", "tension"):
        f = table[mode]
        print(f"{mode:<12} {'x'.join(map(str, f['cells'])):<6} {f['nrms_to_peak']:>12.3f}  "
              f"{f['peak_spheres'] / 1e6:>10.2f} / {f['peak_fe'] / 1e6:<10.2f}  "
              f"{f['work_spheres_J']:>8.1f} / {f['work_fe_J']:<8.1f}")
    f = table["cyclic"]
    print(f"cycle (spheres {cycle['seconds']:.0f} s): nRMS over the path {f['nrms_path']:.3f}; "
          + "; ".join(f"to {leg['target']:.2e}: {leg['spheres'] / 1e6:.2f} / "
                      f"{leg['fe'] / 1e6:.2f} MPa" for leg in f["legs"])
          + " (spheres / FE: each leg's extreme stress)")
    if bending is not None:
        f = table["bending"]
        print(f"bending strip, {'x'.join(map(str, f['cells']))} cells: nRMS to peak "
              f"{f['nrms_to_peak']:.3f}, peak force spheres / FE {f['peak_spheres'] / 1e3:.1f} / "
              f"{f['peak_fe'] / 1e3:.1f} kN at {1e3 * f['strain_at_peak_spheres']:.2f} / "
              f"{1e3 * f['strain_at_peak_fe']:.2f} mm, work {f['work_spheres_J']:.0f} / "
              f"{f['work_fe_J']:.0f} J")
    print(f"results in {out}")
    return 0


def fracture_record(test):
    """The energy balance of a separation test (None for a tension test to 70 % of the peak)."""
    if "fracture_energy" not in test:
        return None
    keys = ("work", "elastic_end", "kinetic", "damping", "links", "closure", "area",
            "work_of_fracture", "strain_peak", "separated", "balance")
    return {k: test[k] for k in keys}


def balance_line(test):
    """The separation test's energy balance in one line."""
    k0, k1 = test["kinetic"]
    return (f"balance: in {test['work'] + k0:.4g} J (ends' work {test['work']:.4g}, kinetic "
            f"{k0:.3g}); found elastic {test['elastic_end']:.4g}, kinetic {k1:.3g}, damping "
            f"{test['damping']:.4g}, links {test['links']['total']:.4g} J (damage "
            f"{test['links']['damage']:.4g}, deleted {test['links']['deleted']:.4g}, shear "
            f"{test['links']['shear']:.4g}, plastic {test['links']['plastic']:.3g}): closure "
            f"{100 * test['closure']:+.2f} %")


def _write(out, radius, size, sample, target, loading, result, macro):
    """calibration.json."""
    from dataclasses import asdict
    from common.files import write_json
    c, t = result["compression"], result["tension"]
    curves = {m: {k: r[k] for k in ("strain", "stress", "strain_mid", "lateral_mid") if k in r}
              for m, r in (("compression", c), ("tension", t))}
    runs = {m: {k: r[k] for k in ("steps", "dt", "seconds")} for m, r in (("compression", c),
                                                                         ("tension", t))}
    write_json(out / "calibration.json", dict(
        radius=radius, size=list(size), spheres=len(sample.radii),
        packing_fraction=sample.fraction, target=asdict(target), loading=asdict(loading),
        params=result["params"], measured=macro, iterations=result["iterations"],
        converged=result["converged"], runs=runs,
        fracture_energy_J_m2=macro["fracture_energy"], tensile_strength_Pa=macro["ft"],
        separation=fracture_record(t), curves=curves))


def _print_result(result, macro, out):
    p = result["params"]
    print(f"CpmMat: young={p['young']:.4g} poisson={p['poisson']:.4g} sigmaT={p['sigmaT']:.4g} "
          f"epsCrackOnset={p['epsCrackOnset']:.4g} relDuctility={p['relDuctility']:.4g} "
          f"equivStrainShearContrib={p['equivStrainShearContrib']:.4g} "
          f"frictionAngle={p['frictionAngle']:.4g} density={p['density']:.4g} (bulk)")
    gf_text = ("" if macro["fracture_energy"] is None
               else f" Gf={macro['fracture_energy']:.1f} J/m²")
    print(f"measured: E={macro['E'] / 1e9:.2f} GPa nu={macro['nu']:.3f} "
          f"fc={macro['fc'] / 1e6:.2f} MPa ft={macro['ft'] / 1e6:.2f} MPa{gf_text} "
          f"({len(result['iterations'])} fit iterations"
          f"{', NOT converged' if result['converged'] is False else ''}); results in {out}")
    t = result["tension"]
    if "links" in t:
        print(balance_line(t) + ("" if t["separated"] else
                                 "; NOT separated: the links' Gf is a lower bound"))
    if t.get("balance"):
        print(f"no Gf: {t['balance']} (work of fracture W/A {t['work_of_fracture']:.1f} J/m²)")


def plot_curves(path, compression, tension, macro, radius):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from common.files import save_figure
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5))
    for ax, run, colour, sign in ((axes[0], compression, "C0", -1), (axes[1], tension, "C3", 1)):
        ax.plot(sign * 1e3 * run["strain"], sign * 1e-6 * run["stress"], colour,
                label=f"{run['mode']} (ends)" if "mode" in run else "separation (ends)")
        if "strain_mid" in run:
            ax.plot(sign * 1e3 * run["strain_mid"], sign * 1e-6 * run["stress"], colour,
                    ls="--", label=f"{run['mode']} (middle third)")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xlabel(f"axial {'shortening' if sign < 0 else 'extension'} strain (‰)")
        ax.set_ylabel(f"{'compressive' if sign < 0 else 'tensile'} stress (MPa)")
        ax.legend(fontsize=8)
    gf = macro["fracture_energy"]
    fig.suptitle(f"R = {radius} m: E = {macro['E'] / 1e9:.1f} GPa, ν = {macro['nu']:.2f}, "
                 f"fc = {macro['fc'] / 1e6:.1f} MPa, ft = {macro['ft'] / 1e6:.2f} MPa"
                 + ("" if gf is None else f", Gf = {gf:.0f} J/m²"), fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)
