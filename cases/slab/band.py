"""The slab's bridging band against the 1D rule (docs/wave1d.md): per scale, its discretisation
ratio and default n_b; the attenuation of a spurious reflection the rule predicts at r = 1
(the default r = ρ, 1.1-2.6 on the slabs measured, is near it) and at the rule's own r for that
band ('auto'), with its LF change; and the n_b the rule would need for its goal.
`python3 -m cases.slab.band` prints the table."""


def band_table():
    """One row per scale: (scale, ratio, n_b, attenuation at r = 1, auto's r, its
    attenuation, its LF change, rule's n_b, rule's r)."""
    from dataclasses import replace
    from cases.slab.zone import slab_grid
    from cases.slab.scales import SCALES
    from cases.slab.spec import SlabSpec
    from orchestrator.coupling.relaxation import Prediction, auto_coupling
    rows = []
    for scale in SCALES:
        s = SlabSpec(scale=scale)
        auto = replace(s, relaxation="auto")
        ratio = slab_grid(s).band_h / (2 * s.radius)
        predict = Prediction(ratio, s.layers, s.variant, s.dt_safety, s.weighting)
        att, lf = predict(auto.relaxation)
        r, nb, _ = auto_coupling(ratio, s.layers, s.variant, s.dt_safety, s.weighting)
        rows.append((scale, ratio, s.layers, predict(1.0)[0], auto.relaxation, att, lf, nb, r))
    return rows


def main():
    print("| scale | ratio h / d | n_b | attenuation at r = 1 | 'auto': r | its attenuation "
          "| its LF change | rule: n_b for 99 % | its r |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for scale, ratio, nb, att1, r, att, lf, rule_nb, rule_r in band_table():
        print(f"| {scale} | {ratio:.2f} | {nb} | {100 * att1:.1f} % | {r:.1f} | {100 * att:.1f} % "
              f"| {100 * lf:+.2f} % | {rule_nb} | {rule_r:.1f} |")


if __name__ == "__main__":
    main()
