"""Coupling from inside a YADE script run by YADE's own launcher, `yade script.py`: one import
and one call, after the script has built its bodies and engines (and stepped once, as CPM
scripts do, to make their cohesive links):

    from cli.attach import attach      # the repository on PYTHONPATH
    model = attach("plate.toml")                # the FE part, DE zone and coupling of a case file
    O.run(2000, True)

The case file is a generic one (docs/case-files.md) without a [de] table: the scene YADE already
holds is the DE part. `attach` builds the FE part and the coupling through the one builder
and inserts the coupling step right after the script's NewtonIntegrator, the same engine that
`run` inserts; YADE's own loop then drives both models. Returns the built model
(orchestrator.builder.Model): its `stepper.last` is the last correction, `fe` the FE model.
"""


def attach(case_file, overrides=()):
    from cases.generic import CaseModel
    from cases.kinds import load_case
    from yade_side import import_yade
    case = load_case(case_file, ["de.current=true", *overrides])
    model = CaseModel(case)
    if model.parts.links_pending and model.parts.consistent:
        raise ValueError(f"{case_file}: the scene has no cohesive links yet (O.iter = "
                         f"{import_yade().Omega().iter}); call O.step() once before attach, as "
                         f"YADE's CPM scripts do to make their links, or set "
                         f'coupling.weighting = "nodal"')
    return model
