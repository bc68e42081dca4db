"""The paper's two a-posteriori checks of a coupled run."""
import numpy as np


def post_run_checks(fe, bridge_damage, tensile_strength, compressive_strength):
    """The paper's two a-posteriori checks: the FE stays elastic, the bridging spheres stay
    undamaged (else the DE zone is too small)."""
    warnings = []
    if fe is not None:
        s = fe.stress()
        if s.max_principal.max() > tensile_strength:
            warnings.append(f"FE principal stress {s.max_principal.max() / 1e6:.2f} MPa exceeds "
                            f"the tensile strength {tensile_strength / 1e6:.2f} MPa: the DE "
                            f"zone may be too small")
        if s.von_mises.max() > compressive_strength:
            warnings.append(f"FE von Mises stress {s.von_mises.max() / 1e6:.2f} MPa exceeds the "
                            f"compressive strength {compressive_strength / 1e6:.1f} MPa")
    if bridge_damage.size and bridge_damage.max() > 0:
        warnings.append(f"{np.count_nonzero(bridge_damage)} bridging spheres are damaged (max "
                        f"{bridge_damage.max():.2f}): the DE zone may be too small")
    return warnings
