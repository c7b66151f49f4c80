"""The friction law: its physics written once (:class:`evtribo.model.friction_law.LoadLaw`),
the choice of ``[analysis] friction_law`` behind a registry
(:mod:`evtribo.analysis.friction.laws`), and a lab's own law, registered from its module or
through an entry point, chosen by that setting in a real analysis."""

from __future__ import annotations

import ast
import logging
import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _plugins import install
from _small_study import AMPLITUDES, analyse, small_study
from evtribo.acquisition.simulator.finger import SimulatedFriction
from evtribo.analysis.friction.laws import (
    LAWS,
    SENSITIVITY_EXPONENT,
    ChosenLaw,
    FittedLaw,
    at_exponent,
    law_choice,
    register,
)
from evtribo.model import TABLE_1
from evtribo.model.friction_law import LoadLaw, added_load
from evtribo.store import memo
from evtribo.util import plugins

SRC = Path(__file__).parents[2] / "src" / "evtribo"

#: A lab's law, as its plug-in module holds it: every subject's forces at m = 0.75 (a pad
#: the lab measured once), its uncertainty not carried.
LAB_LAW = '''
from evtribo.analysis.friction.laws import ChosenLaw
from evtribo.model.friction_law import LoadLaw


class Pad075:
    name = "mylab-pad075"

    def choose(self, fitted):
        return ChosenLaw(fitted, LoadLaw(0.75, fitted.load_ref_N), "mylab-pad075")
'''


@pytest.fixture(autouse=True)
def _no_plugins():
    plugins.forget()
    yield
    LAWS.unregister("mylab-pad075")
    plugins.forget()


# ---------------------------------------------------------------- the physics, once


@settings(max_examples=200, deadline=None)
@given(m=st.floats(0.3, 1.5), fn=st.floats(0.05, 5.0), fel=st.floats(0.0, 2.0),
       mu=st.floats(0.05, 2.0), w0=st.floats(0.05, 5.0))
def test_the_law_inverted_gives_back_the_load_it_was_loaded_with(m, fn, fel, mu, w0):
    law = LoadLaw(m, w0)
    friction = law.friction(mu, fn + fel)
    mu_at_fn = mu * law.coefficient_factor(fn)  # the coefficient without the added load
    assert float(law.added_load(fn, friction, mu_at_fn)) == pytest.approx(fel, abs=1e-9 * fn)
    assert float(friction) == pytest.approx(mu * w0 * ((fn + fel) / w0) ** m, rel=1e-12)


@settings(max_examples=100, deadline=None)
@given(m=st.floats(0.3, 1.5), w0=st.floats(0.05, 5.0),
       load=st.lists(st.floats(-1.0, 5.0), min_size=1, max_size=20))
def test_the_model_and_the_simulated_finger_take_the_one_law(m, w0, load):
    w = np.array(load)
    params = TABLE_1.with_values(m=m, W0=w0)
    finger = SimulatedFriction(params.mu, exponent=m, reference_load_N=w0)
    law = LoadLaw(m, w0)
    np.testing.assert_array_equal(params.friction(w), law.friction(params.mu, w))
    np.testing.assert_array_equal(finger.force(params.mu, w),
                                  law.friction(params.mu, np.maximum(w, 0.0)))
    assert np.all(finger.force(params.mu, w)[w <= 0] == 0.0)  # no load, no friction
    # no load: the coefficient at W0
    np.testing.assert_array_equal(finger.coefficient_at(params.mu, w)[w <= 0], params.mu)
    np.testing.assert_allclose(finger.coefficient_at(params.mu, w)[w > 0],
                               params.mu * (w[w > 0] / w0) ** (m - 1), rtol=1e-12)


def test_amontons_inverted_is_the_study_format_s_force():
    fn, ft, mu = np.array([0.4, 0.6]), np.array([0.3, 0.35]), np.array([0.5, 0.52])
    np.testing.assert_array_equal(added_load(fn, ft, mu), fn * (ft / (fn * mu) - 1.0))
    np.testing.assert_allclose(added_load(fn, ft, mu), ft / mu - fn, rtol=1e-12)


# ---------------------------------------------------------------- the choices


def test_the_builtin_laws_in_the_order_the_documentation_lists_them():
    assert list(LAWS)[:3] == ["auto", "amontons", "power"]
    with pytest.raises(ValueError, match="friction_law must be one of auto, amontons, power, "
                                         "got 'coulomb'"):
        law_choice("coulomb")
    with pytest.raises(ValueError, match="'auto' is registered already"):
        register(LAWS["auto"])


_FITTED = st.builds(FittedLaw, estimate=st.floats(-0.5, 2.0) | st.just(math.nan),
                    estimate_se=st.floats(0.001, 0.5) | st.just(math.nan),
                    told=st.booleans(), dof=st.sampled_from([0.0, 3.0, 40.0]),
                    load_ref_N=st.floats(0.1, 2.0))


@settings(max_examples=300, deadline=None)
@given(fitted=_FITTED)
def test_each_choice_makes_the_fitted_law_the_forces_law_as_documented(fitted):
    holds = fitted.holds_amontons
    auto, amontons, power = (LAWS[n].choose(fitted) for n in ("auto", "amontons", "power"))
    for chosen in (auto, amontons, power):
        assert chosen.fitted is fitted and chosen.law.load_ref_N == fitted.load_ref_N
        low, high = chosen.shown_interval  # shown where the forces carry m's uncertainty
        assert (math.isnan(low) and math.isnan(high)) or chosen.draw_exponent
    assert amontons == ChosenLaw(fitted, LoadLaw(1.0, fitted.load_ref_N), "amontons",
                                 draw_exponent=holds)
    if fitted.estimate > 0:  # power: the fitted m however uncertain
        assert power.exponent == fitted.estimate and power.exponent_source
    else:
        assert power == amontons
    if fitted.told and fitted.estimate > 0 and not holds:
        assert auto == power
    else:  # Amontons', with F_el at m = 0.75 beside it where the interval does not hold 1
        assert auto.exponent == 1.0 and auto.draw_exponent == holds
        assert auto.sensitivity == (None if holds else SENSITIVITY_EXPONENT)
    fixed = at_exponent(fitted, 0.75)
    assert (fixed.exponent, fixed.label, fixed.draw_exponent) == (0.75, "power", False)


def _names_a_law(node: ast.Compare) -> bool:
    """A comparison with a law's name (``"auto"`` where a law is compared: it is also a
    taring and a hum mode; ``"power"`` in the plan's tables is a test's statistical
    power)."""
    text = ast.unparse(node)
    return any(isinstance(c, ast.Constant) and (
        c.value == "amontons" or (c.value == "power" and "quantity" not in text)
        or (c.value == "auto" and "law" in text)) for c in (node.left, *node.comparators))


def test_no_law_is_told_by_its_name_outside_the_laws_package():
    """Adding a law is one module and its registration: nothing else compares a law's
    name."""
    found = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel.startswith("analysis/friction/laws/"):
            continue
        found += [f"{rel}:{node.lineno}: {ast.unparse(node)}"
                  for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
                  if isinstance(node, ast.Compare) and _names_a_law(node)]
    assert not found, found


# ---------------------------------------------------------------- a lab's law, analysed


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """The small study, analysed as it is (``auto``: its presses do not tell m, so its
    forces are Amontons' and F_el at m = 0.75 is beside them); and a copy whose study.toml
    chooses the lab's law (not yet analysed)."""
    base = tmp_path_factory.mktemp("laws")
    plain = small_study(base / "plain")
    lab = base / "lab"
    shutil.copytree(plain, lab)
    with (lab / "study.toml").open("a", encoding="utf-8") as f:
        f.write('\n[analysis]\nfriction_law = "mylab-pad075"\n')
    return lab, analyse(plain, base / "auto")


def _check_lab_law_was_used(out: Path, auto: Path) -> None:
    """The lab's forces are those at m = 0.75, to the last bit, where ``auto`` shows F_el at
    m = 0.75 beside Amontons' forces (a subject whose presses do not tell m): the same law,
    its uncertainty not carried either."""
    lab = pd.read_csv(out / "electrostatic.csv")
    plain = pd.read_csv(auto / "electrostatic.csv")
    assert (lab.friction_law == "mylab-pad075").all()
    assert (lab.friction_exponent == 0.75).all() and lab.friction_exponent_ci_low.isna().all()
    assert (plain.friction_law == "amontons").all() and (plain.friction_exponent == 1).all()
    untold = plain.electrostatic_force_m075_N.notna().to_numpy()
    assert untold.sum() >= len(AMPLITUDES)  # a subject at least
    for mine, at075 in (("electrostatic_force_N", "electrostatic_force_m075_N"),
                        ("electrostatic_force_ci_low_N", "electrostatic_force_m075_ci_low_N"),
                        ("electrostatic_force_ci_high_N", "electrostatic_force_m075_ci_high_N")):
        np.testing.assert_array_equal(lab[mine][untold], plain[at075][untold])
    assert (lab.electrostatic_force_N > plain.electrostatic_force_N).all()
    assert lab.electrostatic_force_m075_N.isna().all()  # no sensitivity: the law says so


def test_a_law_registered_from_a_module_is_chosen_by_friction_law(studies, tmp_path):
    lab, auto = studies
    namespace: dict[str, object] = {}
    exec(LAB_LAW, namespace)  # the lab's module, as its source reads
    register(namespace["Pad075"]())
    _check_lab_law_was_used(analyse(lab, tmp_path / "out"), auto)


def test_a_law_from_an_entry_point_is_chosen_by_friction_law(studies, tmp_path, monkeypatch):
    lab, auto = studies
    install(tmp_path, monkeypatch, "mylab_laws", LAB_LAW,
            entry_points={"evtribo.friction_laws": {"pad075": "mylab_laws:Pad075"}})
    assert "mylab-pad075" in LAWS and list(LAWS)[:3] == ["auto", "amontons", "power"]
    _check_lab_law_was_used(analyse(lab, tmp_path / "out"), auto)


def test_a_plug_in_with_a_builtin_s_name_or_no_law_is_said_and_skipped(tmp_path, monkeypatch,
                                                                        caplog):
    install(tmp_path, monkeypatch, "mylab_bad", "class Auto:\n    name = 'auto'\n"
            "    def choose(self, fitted):\n        raise RuntimeError\n\nTHING = 3\n",
            entry_points={"evtribo.friction_laws": {"auto": "mylab_bad:Auto",
                                                    "thing": "mylab_bad:THING"}})
    with caplog.at_level(logging.WARNING, logger="evtribo.util.plugins"):
        assert list(LAWS) == ["auto", "amontons", "power"]
    said = " ".join(r.getMessage() for r in caplog.records)
    assert "friction law 'auto' is registered already" in said
    assert "names int, not a friction law" in said
    assert type(LAWS["auto"]).__module__ == "evtribo.analysis.friction.laws.auto"


def _forget_software() -> None:
    memo.software_fingerprint.cache_clear()
    memo.plugin_distributions.cache_clear()


def test_a_law_s_new_version_is_not_taken_for_the_results_of_the_old(studies, tmp_path,
                                                                    monkeypatch):
    """An unchanged study is not analysed again: its last results are written again. A lab's
    law is part of what the results depend on, as evtribo's own code is: its new version
    (a plug-in upgraded between two runs) analyses the study again."""
    lab, _ = studies
    study = tmp_path / "lab"
    shutil.copytree(lab, study)
    root = install(tmp_path, monkeypatch, "mylab_laws", LAB_LAW,
                   entry_points={"evtribo.friction_laws": {"pad075": "mylab_laws:Pad075"}})
    _forget_software()
    out = tmp_path / "out"
    analyse(study, out, "--cache-dir", str(tmp_path / "cache"))
    assert (pd.read_csv(out / "electrostatic.csv").friction_exponent == 0.75).all()
    # the lab's next version: the same name, its pad at m = 0.8
    (root / "mylab_laws.py").write_text(LAB_LAW.replace("0.75", "0.8"), encoding="utf-8")
    (root / "mylab_plugin-1.0.dist-info").rename(root / "mylab_plugin-2.0.dist-info")
    monkeypatch.delitem(sys.modules, "mylab_laws")
    plugins.forget()
    _forget_software()
    analyse(study, out, "--cache-dir", str(tmp_path / "cache"), "--force")
    assert (pd.read_csv(out / "electrostatic.csv").friction_exponent == 0.8).all()
    _forget_software()
