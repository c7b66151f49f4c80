"""The friction law of a finger pad's contact: how its friction grows with the load.

A finger pad on glass is a soft contact whose real area grows slower than the load, and the
friction follows the area (Adams et al., J. R. Soc. Interface 2013; Dzidek et al., J. R. Soc.
Interface 2017)::

    F_t = mu W0 (W / W0)**m

with ``W`` the contact's load (the external normal force, plus the electrostatic force when
the voltage is on), ``mu`` the friction coefficient ``F_t / W`` at the load ``W0`` and ``m``
from 2/3 (a dry pad) towards 1; ``m = 1`` is Amontons-Coulomb friction, ``F_t = mu W``.

:class:`LoadLaw` is that law, written once: the model's friction
(:meth:`evtribo.model.ModelParameters.friction`), the analysis's coefficient at a window's
load and its inversion (``evtribo.analysis.friction``), the fit's law
(:func:`evtribo.fit.problem.with_friction_law`) and the simulated finger
(:mod:`evtribo.acquisition.simulator.finger`) all evaluate it here. Each caller keeps its own
floor for a load at or below zero (the model and the simulator take no load as zero friction;
the analysis holds a coefficient's load at 1e-12 N), so that each computes the numbers it
always did, to the last bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["AMONTONS", "LoadLaw", "added_load"]

FloatArray = npt.NDArray[np.float64]


def added_load(normal_N: npt.ArrayLike, friction_N: npt.ArrayLike, mu: npt.ArrayLike,
               exponent: float | npt.ArrayLike = 1.0) -> FloatArray:
    """The load beyond the normal force that a friction shows, the law inverted:
    ``F_n ((F_t / (mu F_n))**(1/m) - 1)``, which is ``F_t / mu - F_n`` when ``m = 1``.

    With the voltage on, this is the electrostatic force ``F_el`` (``W = F_n + F_el``);
    ``mu`` is the coefficient the contact would have at its normal force without it
    (:meth:`LoadLaw.coefficient_factor` times the coefficient at ``W0``), so ``W0`` cancels.

    Parameters
    ----------
    normal_N, friction_N : array_like of float, N
        The normal force and the friction.
    mu : array_like of float
        The friction coefficient ``F_t / F_n`` at the normal force, without the added load.
    exponent : float or array_like
        ``m`` (broadcast against the forces: one per bootstrap replicate as a column).

    Returns
    -------
    ndarray, N
        A friction below ``mu F_n`` gives a negative load; with ``m != 1`` a friction at or
        below zero gives ``-F_n``.
    """
    fn = np.asarray(normal_N, dtype=np.float64)
    ratio = np.asarray(friction_N, dtype=np.float64) / (fn * np.asarray(mu, dtype=np.float64))
    m = np.asarray(exponent, dtype=np.float64)
    if m.ndim == 0 and float(m) == 1.0:
        return np.asarray(fn * (ratio - 1.0))
    return np.asarray(fn * (np.maximum(ratio, 0.0) ** (1.0 / m) - 1.0))


@dataclass(frozen=True)
class LoadLaw:
    """``F_t = mu W0 (W / W0)**m``: the friction of a contact under the load ``W``.

    Attributes
    ----------
    exponent : float
        ``m`` (1: Amontons-Coulomb friction, ``F_t = mu W``).
    load_ref_N : float, N
        ``W0``, the load at which ``mu`` is the coefficient ``F_t / W`` (no effect when
        ``m = 1``).
    """

    exponent: float = 1.0
    load_ref_N: float = 1.0

    @property
    def amontons(self) -> bool:
        """Whether the friction is proportional to the load (``m = 1``)."""
        return self.exponent == 1.0

    def friction(self, mu: npt.ArrayLike, load_N: npt.ArrayLike, *,
                 floor: float = 0.0) -> FloatArray:
        """The friction under *load_N*: ``mu W0 (W / W0)**m``, ``mu W`` when ``m = 1``.

        Parameters
        ----------
        mu : float or array_like of float
            The coefficient at the load ``W0``.
        load_N : float or array_like of float, N
            The contact's load ``W``.
        floor : float, N
            The least load the power is taken of (with ``m != 1``; ``mu W`` is linear and
            takes any load as it is).

        Returns
        -------
        ndarray of float64, N
        """
        c = np.asarray(mu, dtype=np.float64)
        w = np.asarray(load_N, dtype=np.float64)
        if self.exponent == 1.0:
            return np.asarray(c * w)
        w0 = self.load_ref_N
        return np.asarray(c * w0 * (np.maximum(w, floor) / w0) ** self.exponent)

    def coefficient_factor(self, normal_N: npt.ArrayLike, *,
                           floor: float = 1e-12) -> FloatArray:
        """``(F_n / W0)**(m - 1)``: the coefficient ``F_t / F_n`` at each normal force,
        relative to the one at ``W0`` (ones when ``m = 1``).

        Parameters
        ----------
        normal_N : array_like of float, N
            The normal forces (the contact's loads).
        floor : float, N
            The least load the power is taken of (the analysis's 1e-12 N: a window's load is
            never zero).

        Returns
        -------
        ndarray of float64
        """
        fn = np.asarray(normal_N, dtype=np.float64)
        if self.exponent == 1.0:
            return np.ones(fn.shape)
        return np.asarray((np.maximum(fn, floor) / self.load_ref_N) ** (self.exponent - 1.0))

    def added_load(self, normal_N: npt.ArrayLike, friction_N: npt.ArrayLike,
                   mu: npt.ArrayLike) -> FloatArray:
        """:func:`added_load` with this law's exponent: the load beyond *normal_N* that
        *friction_N* shows (the electrostatic force, with the voltage on).

        Parameters
        ----------
        normal_N, friction_N : array_like of float, N
        mu : array_like of float
            The coefficient at the normal force, without the added load.

        Returns
        -------
        ndarray, N
        """
        return added_load(normal_N, friction_N, mu, self.exponent)


#: Amontons' law, ``F_t = mu W`` (``m = 1``; ``W0`` has no effect).
AMONTONS = LoadLaw()
