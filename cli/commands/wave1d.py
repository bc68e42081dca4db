"""`wave1d`: one run of the 1D spurious-reflection model (paper §4) against its reference.
Its options are the fields of cases.wave1d.Wave1DSpec, which holds the defaults."""
from cli.commands._options import add_out, add_spec_options, spec_from_args

NAME = "wave1d"
HELP = "1D spurious reflection at the DE/FE interface (paper §4): one variant vs full Lagrange"


def configure(p):
    from cases.wave1d import Wave1DSpec
    add_spec_options(p, Wave1DSpec)
    add_out(p, "results folder")


def run(args):
    from cases import wave1d
    from orchestrator.run.folder import prepare_out
    spec = spec_from_args(wave1d.Wave1DSpec, args)
    out = prepare_out(args.out, args.force)
    summary = wave1d.run_to_folder(spec, out)
    print(wave1d.result_line(spec, summary, out))
    if spec.rule:
        print(f"rule: {spec.rule}")
    return 0
