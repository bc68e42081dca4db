"""The figures the README and the pages quote from a file a command writes are that file's:
`make bench`'s bench/results.json (docs/benchmarks.md is generated from it whole). A quote is
found by its words, whitespace and line breaks aside; its figure is the file's, rounded as
quoted."""
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = json.loads((ROOT / "bench" / "results.json").read_text())
PAPER = BENCH["per_scale"]["paper"]
GOALS = {g["goal"]: g["figure"] for g in BENCH["goals"]}
HOURS = float(GOALS["coupled 100,000 steps <= 1.5 h on one core (impact window) "
                    "(at paper scale)"].split()[0])
# (page, the quote as a regex with the figure as its group, the figure in the file)
QUOTES = [
    ("README.md", r"ours (\S+) × per step before contact", PAPER["speedup_per_step"]),
    ("README.md", r"and (\S+) × in the impact at paper scale", PAPER["speedup_per_step_impact"]),
    ("docs/measured.md", r"is (\S+) × faster per step than the full model",
     PAPER["speedup_per_step"]),
    ("docs/measured.md", r"\(118,403\) before contact and (\S+) × in the impact",
     PAPER["speedup_per_step_impact"]),
    ("docs/measured.md", r"for (\S+) × fewer spheres; 100,000 steps",
     PAPER["sphere_count_ratio"]),
    ("docs/measured.md", r"100,000 steps in (\S+) h on one core", HOURS),
    ("docs/performance.md", r"the full model \(r = ρ\): (\S+) × per step before contact",
     PAPER["speedup_per_step"]),
    ("docs/performance.md", r"before contact, (\S+) × in the impact, 100,000",
     PAPER["speedup_per_step_impact"]),
    ("docs/performance.md", r"100,000 steps in (\S+) h \(docs/benchmarks.md", HOURS),
    ("docs/usage.md", r"speed a step up (\S+)× on 2 cores", BENCH["thread_speedup"]["2"]),
    ("docs/slab-bias.md", r"coupled model (\S+) × per step before contact",
     PAPER["speedup_per_step"]),
    ("docs/slab-bias.md", r"before contact and (\S+) × in the impact \(docs/benchmarks",
     PAPER["speedup_per_step_impact"]),
]


@pytest.mark.parametrize("page, quote, figure", QUOTES,
                         ids=[f"{p}: {q[:30]}" for p, q, _ in QUOTES])
def test_a_quoted_figure_is_its_source_s(page, quote, figure):
    text = " ".join((ROOT / page).read_text().split())
    found = re.findall(quote, text)
    assert len(found) == 1, f"{page}: the quote /{quote}/ is found {len(found)} times"
    digits = len(found[0].split(".")[1]) if "." in found[0] else 0
    assert float(found[0]) == round(figure, digits), (
        f"{page}: {found[0]} where bench/results.json has {figure:.{digits}f}")
