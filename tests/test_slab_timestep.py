"""The slab's step chosen by its pre-runs (cases.slab.timestep), on made-up energy histories
whose deviation from the half step is known: E(t) = 1 − c·s²·t/T at dt_safety s, so a rung
s differs from its half step by 0.75·c·s² of the impact energy (1 J)."""
import numpy as np
import pytest

from cases.slab import SlabSpec
from cases.slab.timestep import LADDER, TOLERANCE, choose, deviation

C = 0.07     # 0.5 deviates by 1.31 %, 0.4 by 0.84 %


def history(spec, model, safety, calls=None):
    if calls is not None:
        calls.append(safety)
    t = np.linspace(0.0, 1e-3, 20 + int(10 / safety))      # its own sample times
    return t, 1.0 - C * safety**2 * t / 1e-3, 1.0


def test_deviation_is_the_largest_energy_gap_to_the_half_step():
    d = deviation(0.4, lambda s: history(None, None, s))
    assert d == pytest.approx(0.75 * C * 0.4**2, rel=1e-12)


def test_the_largest_passing_rung_is_chosen_and_each_pre_run_made_once():
    spec = SlabSpec(dt_safety="auto", relaxation="auto")
    assert spec.steps is None and spec.relaxation == "auto"     # both wait for the step
    calls, lines = [], []
    chosen = choose(spec, "full", lambda s, m, safety: history(s, m, safety, calls), lines.append)
    assert chosen.dt_safety == 0.4 and LADDER[:2] == (0.5, 0.4)
    assert calls == [0.5, 0.25, 0.4, 0.2]
    tried = chosen.dt_choice["tried"]
    assert [s for s, _ in tried] == [0.5, 0.4] and chosen.dt_choice["passed"]
    assert tried[0][1] > TOLERANCE >= tried[1][1]
    assert "more than 1 %" in lines[0] and "more than" not in lines[1]
    # the chosen spec is a whole one: the table's duration at 0.4, r from the rule at 0.4
    # ⌈4950 × 10.5 / 7 × 0.15 / 0.4⌉: the table's steps over its 7 ms, at 40 m/s's 10.5 ms
    assert chosen.steps == SlabSpec(dt_safety=0.4).steps == 2785
    assert chosen.relaxation == SlabSpec(dt_safety=0.4, relaxation="auto").relaxation


def test_no_passing_rung_takes_the_last_one():
    def gaining(spec, model, safety):
        t = np.linspace(0.0, 1e-3, 30)
        return t, 1.0 + 0.2 * safety * t / 1e-3, 1.0      # 0.1·s of the impact energy
    lines = []
    chosen = choose(SlabSpec(dt_safety="auto"), "full", gaining, lines.append)
    assert chosen.dt_safety == LADDER[-1] and chosen.dt_choice["passed"] is False
    assert len(chosen.dt_choice["tried"]) == len(LADDER)
    assert lines[-1].startswith("slab: no step of 0.5, 0.4, 0.3, 0.2, 0.15 × critical")


def test_auto_is_a_case_file_value_and_other_words_are_not():
    with pytest.raises(ValueError, match='a number or "auto"'):
        SlabSpec(dt_safety="fast")
    with pytest.raises(ValueError, match=r"in \[0.001, 1\] \(× the critical step\)"):
        SlabSpec(dt_safety=1.5)
