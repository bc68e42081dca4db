"""The slab's bridging band against the 1D rule (docs/wave1d.md): per scale, its discretisation
ratio, default n_b and r, the attenuation and LF change the rule predicts for them, and the n_b
the rule would need for its goal. `python3 -m cases.slab.band` prints the table."""


def band_table():
    """One row per scale: (scale, ratio, n_b, r, attenuation, LF change, rule's n_b, rule's r)."""
    from cases.slab.geometry import slab_grid
    from cases.slab.scales import SCALES
    from cases.slab.spec import SlabSpec
    from orchestrator.coupling.relaxation import Prediction, auto_coupling
    rows = []
    for scale in SCALES:
        s = SlabSpec(scale=scale)
        ratio = slab_grid(s).band_h / (2 * s.radius)
        att, lf = Prediction(ratio, s.layers, s.variant, s.dt_safety, s.weighting)(s.relaxation)
        r, nb, _ = auto_coupling(ratio, s.layers, s.variant, s.dt_safety, s.weighting)
        rows.append((scale, ratio, s.layers, s.relaxation, att, lf, nb, r))
    return rows


def main():
    print("| scale | ratio h / d | n_b | r | predicted attenuation | LF change | rule: n_b for 99 % | its r |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for scale, ratio, nb, r, att, lf, rule_nb, rule_r in band_table():
        print(f"| {scale} | {ratio:.2f} | {nb} | {r:.1f} | {100 * att:.1f} % | {100 * lf:+.2f} % "
              f"| {rule_nb} | {rule_r:.1f} |")


if __name__ == "__main__":
    main()
