"""The 1D study's figures."""
from cases.wave1d.spec import Layout
from common.files import save_figure


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
    save_figure(fig, path)


def best(rows, variant, layers, ratio=5):
    """Row of highest attenuation of `variant` at (layers, ratio) in the variants study."""
    cand = [r for r in rows if r["study"] == "variants" and r["variant"] == variant
            and r["layers"] == layers and r["ratio"] == ratio]
    return max(cand, key=lambda r: r["attenuation_percent"]) if cand else None


def plot_study(out, rows, shapes):
    """fig4 (diagonal vs n_b), fig5/fig6 (relaxed full/diagonal vs r per n_b), fig_lf (LF
    change vs r), fig7 (reflected wave shapes at n_b = 3, ratio 5), auto (r rule vs ratio)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    var = [r for r in rows if r["study"] == "variants"]
    if var:
        _fig4(plt, out, var)
        _fig5_6(plt, out, var)
    _fig7(plt, out, rows, shapes)
    auto = [r for r in rows if r["study"] == "auto"]
    if auto:
        _auto(plt, out, auto)


def _fig4(plt, out, var):
    fig, ax = plt.subplots(figsize=(5, 3.5))
    d = sorted((r["layers"], r["attenuation_percent"]) for r in var if r["variant"] == "diagonal")
    ax.plot(*zip(*d), "o-")
    ax.axhline(30, color="0.6", ls=":", label="paper: > 30 %")
    ax.set(xlabel="bridging layers n_b", ylabel="attenuation (%)",
           title="Fig. 4: diagonalised multipliers, r = 1")
    ax.legend()
    fig.tight_layout()
    save_figure(fig, out / "fig4_diagonal.png")


def _fig5_6(plt, out, var):
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
        save_figure(fig, out / name)


def _fig7(plt, out, rows, shapes):
    picks = [("full", 1.0), ("diagonal", 1.0)]
    for v in ("full+relaxation", "diagonal+relaxation"):
        b = best(rows, v, 3)
        picks += [(v, b["relaxation"])] if b else []
        picks += [(v, r["relaxation"]) for r in rows
                  if r["study"] == "auto" and r["ratio"] == 5 and r["variant"] == v]
    picks = [k for k in dict.fromkeys(picks) if k in shapes]
    if not picks:
        return
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
    save_figure(fig, out / "fig7_reflected_waves.png")


def _auto(plt, out, auto):
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
    save_figure(fig, out / "auto_relaxation.png")
