"""The population models a study's population may be estimated with, by the name study.toml's
``[population] model`` gives them.

A model (:class:`~evtribo.population.models.interface.PopulationModel`) fits one drive's cells
of every subject (:class:`~evtribo.population.models.interface.DriveCells`) and gives the
population's estimates; :func:`evtribo.population.power_law.condition_estimates` runs the
chosen one as the primary analysis, refits it without each subject it names as far from the
others, and adds the meta-analysis as the second method. The builtins, in the order the
documentation lists them: ``mixed`` (the default, :mod:`~evtribo.population.models.mixed`)
and ``meta-analysis`` (:mod:`~evtribo.population.models.meta`). A lab adds its own in one
module, registered with :func:`register` or through the entry point group
``evtribo.population_models`` (the object it names is a model, or a class of one made without
arguments): its ``name`` is then a value of ``[population] model``.
"""

from __future__ import annotations

from evtribo.population.models.interface import (
    DriveCells,
    FarSubjects,
    ModelFit,
    PopulationModel,
)
from evtribo.population.models.meta import META_MAX_LOG_SE, MetaAnalysis
from evtribo.population.models.mixed import MixedModel
from evtribo.util.plugins import Registry

__all__ = ["DEFAULT_MODEL", "ENTRY_POINTS", "META_ANALYSIS", "META_MAX_LOG_SE", "MODELS",
           "DriveCells", "FarSubjects", "ModelFit", "PopulationModel", "population_model",
           "register"]

#: The entry point group of plug-ins' population models.
ENTRY_POINTS = "evtribo.population_models"
#: The model of the primary rows when study.toml names none.
DEFAULT_MODEL = "mixed"
#: The meta-analysis of log F_el: every drive's second method (the only one of a drive of
#: one amplitude).
META_ANALYSIS = MetaAnalysis()


def _model(obj: object) -> PopulationModel | None:
    """A population model, from a plug-in's object (a class is made into one)."""
    if isinstance(obj, type):
        try:
            obj = obj()
        except TypeError:
            return None
    if isinstance(obj, PopulationModel) and isinstance(getattr(obj, "name", None), str):
        return obj
    return None


#: Every population model by name: the builtins (mixed, meta-analysis), then the plug-ins'.
MODELS: Registry[PopulationModel] = Registry(ENTRY_POINTS, "population model", check=_model,
                                             key=lambda entry, model: model.name)
for _builtin in (MixedModel(), META_ANALYSIS):
    MODELS.register(_builtin.name, _builtin)


def register(model: PopulationModel) -> None:
    """Add a population model under its ``name``.

    Parameters
    ----------
    model : PopulationModel

    Raises
    ------
    ValueError
        A name registered already, or an object that is no model.
    """
    MODELS.register(str(getattr(model, "name", "")), model)


def population_model(name: str) -> PopulationModel:
    """The population model of a name.

    Parameters
    ----------
    name : str
        ``[population] model``.

    Returns
    -------
    PopulationModel

    Raises
    ------
    KeyError
        No model of that name.
    """
    return MODELS[name]
