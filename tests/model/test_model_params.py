"""ModelParameters: Table 1 defaults, metadata, validation, --set parsing."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.errors import ConfigError
from evtribo.model import TABLE_1, ModelParameters


def test_table_1_defaults():
    p = ModelParameters()
    assert p == TABLE_1
    assert (p.mu, p.R, p.E_star) == (0.5, 0.01, 40e3)
    assert (p.eps_sc, p.eps_i, p.eps_L) == (1650.0, 3.35, 1.0)
    assert (p.h_sc, p.h_i, p.h_L, p.eps_0) == (300e-6, 1e-6, 5e-6, 8.854e-12)


def test_names_and_info_cover_every_field():
    names = ModelParameters.names()
    assert names == ("mu", "R", "E_star", "eps_sc", "eps_i", "eps_L", "h_sc", "h_i", "h_L",
                     "eps_0", "r_sc", "r_g", "m", "W0")
    info = ModelParameters.info()
    assert [row.name for row in info] == list(names)
    for row in info:
        assert row.unit and row.description
        assert row.default == getattr(TABLE_1, row.name)
    assert {row.name: row.unit for row in info}["E_star"] == "Pa"


def test_frozen_and_replace():
    with pytest.raises(dataclasses.FrozenInstanceError):
        TABLE_1.mu = 0.3  # type: ignore[misc]
    p = TABLE_1.with_values(mu=0.3, h_L=2e-6)
    assert (p.mu, p.h_L, TABLE_1.mu) == (0.3, 2e-6, 0.5)
    assert TABLE_1.replace({"R": 0.02}).R == 0.02
    assert p.as_dict()["mu"] == 0.3


def test_effective_gap():
    assert math.isclose(TABLE_1.effective_gap, 300e-6 / 1650 + 5e-6 + 1e-6 / 3.35)


@pytest.mark.parametrize(("name", "value"), [
    ("h_sc", -1e-6), ("h_i", -1e-9), ("h_L", -5e-6), ("E_star", 0.0), ("E_star", -1.0),
    ("mu", 0.0), ("mu", -0.1), ("R", 0.0), ("eps_sc", 0.0), ("eps_0", -1.0),
    ("R", math.nan), ("E_star", math.inf), ("mu", "0.5"), ("mu", True), ("R", None),
    ("R", [0.01]), ("mu", 0.5 + 0j),
])
def test_bad_values_raise_config_error_naming_the_parameter(name, value):
    with pytest.raises(ValueError, match=name) as exc:
        ModelParameters(**{name: value})
    assert isinstance(exc.value, ConfigError)
    assert exc.value.key == name


def test_numpy_numbers_accepted():
    p = ModelParameters(h_L=np.float32(2e-6), R=np.array(0.02), mu=1)
    assert p.h_L == pytest.approx(2e-6) and p.R == 0.02 and type(p.mu) is float


def test_zero_thicknesses_allowed_but_not_all():
    assert ModelParameters(h_L=0.0).h_L == 0.0
    with pytest.raises(ConfigError, match="no gap"):
        ModelParameters(h_L=0.0, h_sc=0.0, h_i=0.0)


def test_unknown_name():
    with pytest.raises(ConfigError) as exc:
        TABLE_1.with_values(radius=1.0)
    assert exc.value.key == "radius"
    assert "unknown" in str(exc.value)


def test_assignments():
    p = TABLE_1.with_assignments(["mu=0.3", " h_L = 2e-6 "])
    assert (p.mu, p.h_L) == (0.3, 2e-6)


@pytest.mark.parametrize(("text", "key"), [
    ("mu", "mu"), ("=3", "=3"), ("nope=1", "nope"), ("mu=abc", "mu"), ("h_L=-1", "h_L"),
    ("E_star=0", "E_star"),
])
def test_bad_assignments(text, key):
    with pytest.raises(ConfigError) as exc:
        TABLE_1.with_assignments([text])
    assert exc.value.key == key


_values = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 5),
                    st.booleans(), st.text(max_size=3), st.just(np.float32(2.5e-6)))


@given(changes=st.dictionaries(st.sampled_from([*ModelParameters.names(), "nope"]), _values,
                               max_size=4))
def test_a_copy_with_values_is_the_parameters_made_afresh(changes):
    """with_values checks only what it changes (the rest was checked when the parameters
    were made): it gives the parameters ModelParameters(...) gives, or the same error."""
    def outcome(make):
        try:
            return make()
        except ConfigError as err:
            return ("error", err.key, str(err))

    base = TABLE_1.with_values(h_sc=0.0, r_g=1e-3)
    if "nope" in changes:
        got = outcome(lambda: base.with_values(changes))
        assert got[:2] == ("error", "nope")
        return
    want = outcome(lambda: ModelParameters(**{**base.as_dict(), **changes}))
    got = outcome(lambda: base.with_values(changes))
    assert got == want
    if not isinstance(got, tuple):
        assert {n: type(getattr(got, n)) for n in got.names()} == dict.fromkeys(got.names(),
                                                                               float)
