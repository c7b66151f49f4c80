"""Which model parameters to fit, and the fixed ones from Table 1 or the user's TOML.

Names are read from :class:`evtribo.model.ModelParameters` itself (its dataclass fields), so a
parameter added to the model can be fitted without touching this module.

The user's parameter file is a TOML file of ``name = value`` pairs in SI units, at top level
or under a ``[model]`` table::

    # my-params.toml
    E_star = 55e3     # Pa
    h_sc = 250e-6     # m
"""

from __future__ import annotations

import dataclasses
import tomllib
from collections.abc import Iterable
from pathlib import Path

from evtribo.errors import ConfigError, toml_problem
from evtribo.model.params import TABLE_1, ModelParameters

__all__ = ["DEFAULT_FIT", "load_parameters", "name_list", "parameter_names", "parameter_unit",
           "resolve_fit_names"]

#: Fitted by default: the equivalent air gap, per subject.
DEFAULT_FIT: tuple[str, ...] = ("h_L",)


def parameter_names() -> tuple[str, ...]:
    """Names of the model's parameters, from the ``ModelParameters`` fields.

    Returns
    -------
    tuple of str
        In Table 1's order.
    """
    return tuple(f.name for f in dataclasses.fields(ModelParameters))


def parameter_unit(name: str) -> str:
    """SI unit of parameter *name* (``"1"`` for dimensionless ones).

    Parameters
    ----------
    name : str
        A parameter of :class:`~evtribo.model.ModelParameters`.

    Returns
    -------
    str
        Its unit.
    """
    for f in dataclasses.fields(ModelParameters):
        if f.name == name:
            return str(f.metadata.get("unit", ""))
    raise ConfigError(f"unknown model parameter; known: {', '.join(parameter_names())}",
                      key=name)


def name_list(names: str | Iterable[str]) -> list[str]:
    """Names given as ``"a,b"`` or as a list: stripped, blanks and repeats left out.

    Parameters
    ----------
    names : str or iterable of str

    Returns
    -------
    list of str
        In the order given.
    """
    items = names.split(",") if isinstance(names, str) else list(names)
    return list(dict.fromkeys(n.strip() for n in items if n.strip()))


def resolve_fit_names(names: str | Iterable[str] | None) -> tuple[str, ...]:
    """Validate the names of the parameters to fit.

    Parameters
    ----------
    names : str or iterable of str or None
        ``"h_L,E_star"`` or ``["h_L", "E_star"]``; None gives :data:`DEFAULT_FIT`.

    Returns
    -------
    tuple of str
        The names, without duplicates, in the order given.

    Raises
    ------
    ConfigError
        Naming every unknown parameter and listing the known ones (``key="fit"``).
    """
    if names is None:
        return DEFAULT_FIT
    wanted = name_list(names)
    if not wanted:
        raise ConfigError("no parameter to fit", key="fit")
    known = parameter_names()
    unknown = [n for n in wanted if n not in known]
    if unknown:
        raise ConfigError(f"unknown model parameter(s) {', '.join(map(repr, unknown))}; "
                          f"known: {', '.join(known)}", key="fit")
    fixed_by_nature = [n for n in wanted if n == "eps_0"]
    if fixed_by_nature:
        raise ConfigError("eps_0 is a physical constant and cannot be fitted", key="fit")
    law = [n for n in wanted if n in ("m", "W0")]
    if law:
        raise ConfigError(f"{', '.join(law)}: the friction law is measured by evtribo analyze "
                          "from the OFF windows (electrostatic.csv's friction_exponent), and "
                          "compare uses it as it is: it cannot be fitted", key="fit")
    return tuple(wanted)


def load_parameters(path: str | Path | None,
                    base: ModelParameters = TABLE_1) -> ModelParameters:
    """The fixed parameters: *base* (Table 1) updated from a TOML file.

    Parameters
    ----------
    path : str or Path or None
        TOML of ``name = value`` pairs in SI units (top level or under ``[model]``);
        None returns *base*.
    base : ModelParameters
        Values for the names the file does not set.

    Raises
    ------
    ConfigError
        For a missing or unreadable file, an unknown name, a value that is not a number or
        is out of range; ``path`` is the file and ``key`` the parameter.

    Returns
    -------
    ModelParameters
        *base* with the file's values.
    """
    if path is None:
        return base
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as err:
        raise ConfigError(f"cannot read the parameter file: {err.strerror or err}",
                          path=file) from err
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        reason, line, key = toml_problem(err, text)
        raise ConfigError(f"not valid TOML: {reason}", path=file, line=line, key=key) \
            from err
    if set(data) == {"model"} and isinstance(data["model"], dict):
        data, prefix = data["model"], "model."
    else:
        prefix = ""
    known = parameter_names()
    values: dict[str, float] = {}
    for key, value in data.items():
        if key not in known:
            raise ConfigError(f"unknown model parameter; known: {', '.join(known)}",
                              path=file, key=prefix + key)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"expected a number in SI units "
                              f"({parameter_unit(key)}), got {value!r}",
                              path=file, key=prefix + key)
        values[key] = float(value)
    try:
        return base.with_values(values)
    except ConfigError as err:
        raise ConfigError(err.message, path=file, key=prefix + (err.key or "")) from err
