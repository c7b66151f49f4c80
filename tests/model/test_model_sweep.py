"""Every public model function is finite and non-negative over a sweep of loads, voltages
and parameter sets, broadcasts over arrays, and gives the same result element-wise."""

import inspect

import numpy as np
import pytest

from evtribo import model
from evtribo.model import TABLE_1

FORCES = np.array([1e-3, 0.01, 0.1, 0.5, 2.0, 10.0])
VOLTAGES = np.array([0.0, 1.0, -60.0, 140.0, 500.0])
PARAMS = [
    TABLE_1,
    TABLE_1.with_values(mu=0.3),
    TABLE_1.with_values(h_L=0.0),
    TABLE_1.with_values(R=0.1, E_star=1e6, eps_i=10.0, h_i=1e-5),
    TABLE_1.with_values(E_star=5e3, h_sc=50e-6, eps_L=2.0),
]


def _call(fn, normal_force, voltage, params):
    names = inspect.signature(fn).parameters
    kwargs = {"normal_force": normal_force, "voltage": voltage, "params": params}
    return fn(**{k: v for k, v in kwargs.items() if k in names})


def test_functions_tuple_is_public():
    for fn in model.functions:
        assert fn.__name__ in model.__all__
        positional = [name for name, p in inspect.signature(fn).parameters.items()
                      if p.kind is p.POSITIONAL_OR_KEYWORD]
        assert set(positional) <= {"normal_force", "voltage", "params"}


@pytest.mark.parametrize("params", PARAMS, ids=range(len(PARAMS)))
@pytest.mark.parametrize("fn", model.functions, ids=lambda f: f.__name__)
def test_finite_and_non_negative(fn, params):
    out = np.asarray(_call(fn, FORCES[:, None], VOLTAGES[None, :], params))
    assert np.all(np.isfinite(out)), f"{fn.__name__}: {out}"
    assert np.all(out >= 0), f"{fn.__name__}: {out}"


@pytest.mark.parametrize("fn", model.functions, ids=lambda f: f.__name__)
def test_broadcasts_like_scalars(fn):
    grid = np.asarray(_call(fn, FORCES[:, None], VOLTAGES[None, :], TABLE_1))
    scalar = _call(fn, 0.5, 140.0, TABLE_1)
    assert np.ndim(scalar) == 0
    names = inspect.signature(fn).parameters
    if "normal_force" in names and "voltage" in names:
        assert grid.shape == (len(FORCES), len(VOLTAGES))
        assert grid[3, 3] == pytest.approx(scalar, rel=1e-12)


@pytest.mark.parametrize("fn", [model.friction_force, model.friction_force_md],
                         ids=lambda f: f.__name__)
def test_friction_increases_with_load_and_voltage(fn):
    out = np.asarray(fn(FORCES[:, None], np.array([0.0, 60.0, 140.0])[None, :]))
    assert np.all(np.diff(out, axis=0) > 0) and np.all(np.diff(out, axis=1) > 0)
