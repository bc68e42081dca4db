"""`wave1d`: one run of the 1D spurious-reflection model (paper §4) against its reference."""
from orchestrator.commands._options import add_out, add_weighting, relaxation_arg

NAME = "wave1d"
HELP = "1D spurious reflection at the DE/FE interface (paper §4): one variant vs full Lagrange"


def configure(p):
    p.add_argument("--variant", choices=("full", "diagonal"), default="diagonal",
                   help="multiplier solver (default: diagonal)")
    p.add_argument("--relaxation", type=relaxation_arg, default="auto",
                   help="relaxation r >= 1, or 'auto' (default): the rule of docs/wave1d.md")
    p.add_argument("--layers", type=int, default=3, help="bridging FE layers n_b (default 3)")
    p.add_argument("--ratio", type=int, default=5,
                   help="FE element length / sphere spacing (default 5)")
    p.add_argument("--dt-safety", type=float, default=0.8,
                   help="time step / the smaller critical step (default 0.8)")
    add_weighting(p, "nodal")
    add_out(p, "results folder")


def run(args):
    from cases import wave1d
    from orchestrator.results import prepare_out, write_json
    spec = wave1d.Wave1DSpec(variant=args.variant, relaxation=args.relaxation,
                             layers=args.layers, ratio=args.ratio, dt_safety=args.dt_safety,
                             weighting=args.weighting)
    out = prepare_out(args.out, args.force)
    reference = wave1d.run(spec.reference())
    result = reference if spec == spec.reference() else wave1d.run(spec)
    summary = wave1d.summarise(spec, result, reference)
    write_json(out / "summary.json", summary)
    wave1d.plot_wave(out / "wave.png", spec, result, reference)
    print(f"wave1d {spec.variant}, r = {spec.relaxation:g}, n_b = {spec.layers}, ratio "
          f"{spec.ratio}: attenuation {summary['attenuation_percent']:.2f} %, LF transmission "
          f"change {summary['low_frequency_transmission_change_percent']:+.3f} %; results in {out}")
    return 0
