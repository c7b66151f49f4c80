"""``evtribo plan``: a design's expected intervals and power, from pilots recorded and
analysed on the simulated rig and studies simulated at the cell level."""

from __future__ import annotations

import math

import numpy as np
import pytest

from evtribo.cli import main
from evtribo.errors import ConfigError
from evtribo.population.plan import Design, Expected, pilot_errors, plan_study

SHORT = {"trial_s": 8.0, "amplitudes": (60.0, 140.0)}


def test_more_subjects_give_narrower_intervals_and_more_power():
    """4 against 12 subjects of the same population, the pilots' errors shared: the
    population's F_el and exponent intervals narrow, the power grows, and a subject's own
    interval is the pilots' whatever the number of subjects."""
    progress: list[str] = []
    plan = plan_study(Design(subjects=(4, 12), **SHORT), Expected(contrast=1.5), runs=12,
                      pilots=1, progress=progress.append)
    t = plan.table
    assert set(t["subjects"]) == {4, 12}
    assert progress[0].startswith("pilot: recording trial 1 of 2 on the simulated rig")
    assert progress[-1] == "12 subjects: study 12 of 12 at the cell level"

    def value(k: int, quantity: str, amp: float | None = None) -> float:
        rows = t[(t["subjects"] == k) & (t["quantity"] == quantity)]
        if amp is not None:
            rows = rows[np.isclose(rows["amplitude_V"], amp)]
        return float(rows["value"].iloc[0])

    for amp in (60.0, 140.0):
        assert value(12, "population F_el", amp) < value(4, "population F_el", amp)
        assert value(4, "subject F_el", amp) == value(12, "subject F_el", amp) > 0
        assert value(4, "subject F_el", amp) == pytest.approx(
            1.959964 * plan.pilot.error_N[list(plan.pilot.amplitudes).index(amp)])
    assert value(12, "exponent") < value(4, "exponent")
    assert value(12, "power") >= value(4, "power")
    assert 0.0 <= value(4, "power") <= 1.0
    assert (t[t["quantity"] == "population F_el"]["runs"] == 12).all()  # every fit made


def test_the_strokes_scatter_widens_a_subject_s_interval():
    """The same pilot with its strokes' friction scattered by 10 % instead of none: a
    subject's F_el is known less well at the highest amplitude."""
    expected = Expected(force_N=0.1)
    calm = pilot_errors(Design(stroke_scatter=0.0, **SHORT), expected, pilots=1, seed=3)
    scattered = pilot_errors(Design(stroke_scatter=0.10, **SHORT), expected, pilots=1,
                             seed=3)
    assert scattered.error_N[-1] > calm.error_N[-1]


def test_the_command_prints_the_plan(capsys):
    assert main(["plan", "--subjects", "5", "--runs", "10", "--pilots", "1",
                 "--trial-length", "8", "--amplitudes", "60,140"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("a subject's F_el, 95 % interval (from the pilots): ±")
    row = next(line for line in out.splitlines() if line.strip().startswith("5 "))
    assert row.count("\u00d7/\u00f7") == 2 and "±" in row and row.rstrip().endswith("%")


@pytest.mark.parametrize(("kw", "key"), [({"subjects": (2,)}, "--subjects"),
                                         ({"amplitudes": (100.0,)}, "--amplitudes"),
                                         ({"on_s": 30.0}, "--on-time")])
def test_a_design_that_cannot_be_is_refused_by_name(kw, key):
    with pytest.raises(ConfigError) as err:
        Design(**kw)
    assert err.value.key == key


def test_a_force_the_model_cannot_give_is_refused_before_any_simulation():
    with pytest.raises(ConfigError, match="the seed paper's model gives") as err:
        plan_study(Design(amplitudes=(10.0, 20.0)), Expected(force_N=5.0), runs=10)
    assert err.value.key == "--force"
    assert math.isfinite(Expected().force_N)
