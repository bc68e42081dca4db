"""Options several subcommands share."""
from orchestrator.bridging import WEIGHTINGS


def add_weighting(p, default):
    p.add_argument("--weighting", choices=WEIGHTINGS, default=default,
                   help="bridging weights: 'consistent' puts α, β inside the partners' masses "
                        "and stiffnesses (energy-conserving), 'nodal' is the paper's "
                        f"(default {default})")


def add_out(p, what="results folder", required=True):
    p.add_argument("--out", required=required, help=what)
    p.add_argument("--force", action="store_true", help="replace an existing results folder")


def relaxation_arg(text):
    """'auto' or a number (its range is checked by the case)."""
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"--relaxation must be a number or 'auto', got {text!r}") from None
