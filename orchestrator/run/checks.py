"""The paper's two a-posteriori checks of a coupled run, and which FE cells they read."""
import numpy as np


def fe_cells_checked(model):
    """Mask of the FE cells whose stress and damage the checks read (the zone's trip during
    the run, orchestrator.run.autozone, and the post-run check): those outside the bridging
    band; None (every cell) for a model without a band. In the band the FE's strain is the
    spheres' (the coupling holds them together), whose hot spots at the packing's scale are
    no continuum's, and the band's own check is its links."""
    fe = model.fe
    if fe is None or model.bridging is None:
        return None
    return ~model.bridging.contains(fe.nodes[fe.cell_nodes].mean(axis=1))


def post_run_checks(fe_peak, bridge_damage, tensile_strength, compressive_strength,
                    fe_damage=None, damage_level=None):
    """The paper's two a-posteriori checks: the FE stays elastic over the whole run (fe_peak:
    its largest cell stresses over the run, outside the bridging band,
    orchestrator.run.outputs.fe_peak; None without FE), the bridging spheres stay undamaged
    (else the DE zone is too small). Where the FE carries damage (fe_damage:
    orchestrator.run.outputs.fe_damage), its stresses are the law's and the first check is
    that no cell outside the band went as far into its softening as the zone's trip level:
    damage below `damage_level`."""
    warnings = []
    if fe_damage is not None:
        worst = fe_damage["max_checked"]
        if worst >= damage_level:
            warnings.append(f"FE damage {worst:.3f} reaches {damage_level:g} (the zone's trip "
                            f"level) in the FE part outside the bridging band: the DE zone "
                            f"may be too small")
    elif fe_peak is not None:
        s1, vm = fe_peak["max_principal_Pa"], fe_peak["von_mises_Pa"]
        if s1 > tensile_strength:
            warnings.append(f"FE principal stress {s1 / 1e6:.2f} MPa (at t = "
                            f"{fe_peak['max_principal_t_s'] * 1e3:.3g} ms) exceeds the tensile "
                            f"strength {tensile_strength / 1e6:.2f} MPa: the DE zone may be "
                            f"too small")
        if vm > compressive_strength:
            warnings.append(f"FE von Mises stress {vm / 1e6:.2f} MPa (at t = "
                            f"{fe_peak['von_mises_t_s'] * 1e3:.3g} ms) exceeds the compressive "
                            f"strength {compressive_strength / 1e6:.1f} MPa")
    if bridge_damage.size and bridge_damage.max() > 0:
        warnings.append(f"{np.count_nonzero(bridge_damage)} bridging spheres are damaged (max "
                        f"{bridge_damage.max():.2f}): the DE zone may be too small")
    return warnings
