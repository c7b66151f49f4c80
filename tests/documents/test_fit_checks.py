"""fit.json's checks of the population's mixed model, as fields: the force at an amplitude
holds where only the exponent is not determined; an older fit.json's text is read as all
failed unless it says ok."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from evtribo.documents.fit import FitDocument
from evtribo.documents.population_table import EXPONENT, FORCE, Checks, Drive
from evtribo.population.convergence import Convergence, OptimiserRun

RUNS = (OptimiserRun("L-BFGS-B", 1.0, (0.0, 2.0), True),)


@given(st.booleans(), st.booleans(), st.booleans(), st.booleans())
def test_the_checks_go_through_fit_json_as_fields(finite, pd_, agree, determined):
    conv = Convergence(finite, pd_, agree, RUNS, ("a problem",), "", determined)
    checks = conv.as_checks()
    assert (checks.finite, checks.hessian_pd, checks.agree, checks.determined) == (
        finite, pd_, agree, determined)
    assert checks.text == conv.summary() and checks.ok == conv.ok
    doc = FitDocument({"population": {"checks": {"square 10000 Hz": {
        **checks.as_json(), "waveform": "square", "frequency_Hz": 10000.0}}}})
    assert doc.population_checks() == {Drive("square", 10000.0): checks}
    back = doc.population_checks()[Drive("square", 10000.0)]
    assert back.holds(FORCE) == (finite and pd_ and agree)
    assert back.holds(EXPONENT) == (finite and pd_ and agree and determined)


def test_an_undetermined_exponent_leaves_the_force_standing():
    conv = Convergence(True, True, True, RUNS, ("the exponent is hardly determined",), "",
                       determined=False)
    assert conv.as_checks().holds(FORCE) and not conv.as_checks().holds(EXPONENT)


def test_an_older_fit_json_s_text_is_read_as_all_failed_unless_ok():
    doc = FitDocument({"population": {"checks": {
        "square 10000 Hz": "the exponent is hardly determined by these data",
        "sine 10 Hz": "ok (3 optimisers agree)"}}})
    got = doc.population_checks()
    assert got[Drive("square", 10000.0)] == Checks.of_text(
        "the exponent is hardly determined by these data")
    assert not got[Drive("square", 10000.0)].holds(FORCE)
    assert got[Drive("sine", 10.0)].ok
    assert FitDocument({}).population_checks() == {}
