"""A fingertip's friction coefficient as the literature describes it: not one number.

The ideal simulated finger has Coulomb friction with a constant ``mu``. A real fingertip on
glass does not (``docs/simulator.md`` gives the sources and the ranges):

- **moisture and occlusion**: sweat trapped under the finger softens the stratum corneum and
  the real contact grows with first-order kinetics, so ``mu`` rises with the time the finger
  has been in contact, saturating after a few time constants (Dzidek et al., PNAS 2017;
  Adams et al., J. R. Soc. Interface 2013; Pasumarty et al., Tribol. Lett. 2011)::

      moisture(t) = 1 + rise * (1 - exp(-t_contact(t) / tau))

  where ``t_contact`` counts only the time in contact (a lift-off pauses it);
- **sliding speed**: finger-pad friction depends on velocity, ``mu ~ (v / v_ref)**beta``
  with a small exponent (Pasumarty 2011; Adams 2013), and a person's strokes differ in speed;
- **direction**: forward and backward strokes differ (finger posture, the ridges'
  direction), ``mu * (1 + a * d)`` with ``d`` the sliding direction;
- **trial to trial**: the skin's state differs between trials (``mu`` of each trial drawn
  about the subject's);
- **load**: a finger pad on smooth glass is a soft Hertzian contact whose real area grows
  as ``W**(2/3)``, and its friction follows the area: ``F_t = c * W**m`` with ``m`` from
  2/3 (the dry limit, ``mu ~ W**(-1/3)``) towards 1, ``m`` about 0.67-0.9 for finger pads
  (Adams et al., J. R. Soc. Interface 2013; Dzidek et al., J. R. Soc. Interface 2017).
  Under electroadhesion the electrostatic force loads the same contact: ``W = F_n +
  F_el``. The law is written about the subject's target press ``W_0``,
  ``F_t = mu * W_0 * (W / W_0)**m``, so that ``mu`` is the coefficient at that press
  (and ``m = 1`` is Amontons-Coulomb friction, ``F_t = mu * W``).

:class:`SimulatedFriction` combines them; the simulator evaluates it at every sample of the
tangential cell and records it as the truth. The load's part is the friction law of the
model's physics (:class:`evtribo.model.friction_law.LoadLaw`), not a copy of its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from evtribo.model.friction_law import LoadLaw

__all__ = ["PRESS_PERIOD_S", "SimulatedFriction", "contact_time", "press_cycle"]

if TYPE_CHECKING:
    from evtribo.acquisition.simulator.config import SubjectParams

FloatArray = npt.NDArray[np.float64]


def contact_time(t: npt.ArrayLike, off_start: npt.ArrayLike, off_end: npt.ArrayLike,
                 ramp_s: float) -> FloatArray:
    """Time spent in contact since the trial's start at times *t*, s.

    The finger is off the screen during the periods ``[off_start, off_end]`` (each leaving
    over *ramp_s* after its start and touching down over *ramp_s* before its end; a ramp
    counts half).

    Parameters
    ----------
    t : array_like of float, s
        Times from the trial's start.
    off_start, off_end : array_like of float, s
        The off-periods, sorted and disjoint.
    ramp_s : float, s
        Time to leave and to come back.

    Returns
    -------
    ndarray of float64, s
    """
    t = np.asarray(t, dtype=np.float64)
    out = np.maximum(t, 0.0)
    for a, b in zip(np.asarray(off_start, float), np.asarray(off_end, float), strict=True):
        lo, hi = max(a + 0.5 * ramp_s, 0.0), b - 0.5 * ramp_s
        if hi > lo:
            out -= np.clip(t - lo, 0.0, hi - lo)
    return out


@dataclass(frozen=True)
class SimulatedFriction:
    """A trial's friction at each instant.

    ``mu(t) = mu0 * moisture(t) * (v / v_ref)**speed_exponent * (1 + asymmetry * d)``, the
    coefficient at the reference load ``W_0``; the friction under a load ``W`` is
    ``F_t = mu(t) * W_0 * (W / W_0)**exponent`` (:meth:`force`, the law of
    :attr:`load_law`).

    Attributes
    ----------
    mu0 : float
        The trial's coefficient at first contact, at the reference speed, averaged over the
        two directions.
    moisture_rise : float
        Relative rise of ``mu`` once the contact has saturated (0.3: 30 % higher).
    moisture_time_s : float, s
        Time constant of the rise, in contact time.
    speed_exponent : float
        ``beta`` of the speed dependence.
    reference_speed_m_s : float, m/s
        Speed at which the speed factor is 1.
    asymmetry : float
        ``a`` of the direction dependence.
    exponent : float
        ``m`` of the friction's dependence on the load (1: Amontons-Coulomb).
    reference_load_N : float, N
        ``W_0``, the load at which ``mu`` is the coefficient ``F_t / W``.
    """

    mu0: float
    moisture_rise: float = 0.0
    moisture_time_s: float = 8.0
    speed_exponent: float = 0.0
    reference_speed_m_s: float = 0.02
    asymmetry: float = 0.0
    exponent: float = 1.0
    reference_load_N: float = 1.0

    @classmethod
    def of(cls, subject: SubjectParams, rng: np.random.Generator) -> SimulatedFriction:
        """The subject's friction in one trial (its coefficient drawn about the subject's
        when trials differ, ``mu_trial_spread``).

        Parameters
        ----------
        subject : SubjectParams
        rng : numpy.random.Generator

        Returns
        -------
        SimulatedFriction
        """
        mu0 = subject.mu
        if subject.mu_trial_spread > 0:
            mu0 *= float(np.clip(1.0 + subject.mu_trial_spread * rng.standard_normal(),
                                 0.5, 1.5))
        return cls(mu0, subject.moisture_rise, subject.moisture_time_s,
                   subject.speed_exponent, subject.sliding_speed_m_s,
                   subject.direction_asymmetry, subject.friction_exponent,
                   subject.normal_force_N)

    @property
    def load_law(self) -> LoadLaw:
        """How the friction grows with the load: ``m`` and ``W_0``
        (:class:`~evtribo.model.friction_law.LoadLaw`)."""
        return LoadLaw(self.exponent, self.reference_load_N)

    def force(self, mu: npt.ArrayLike, load_N: npt.ArrayLike) -> FloatArray:
        """The friction's magnitude under *load_N* with the coefficient *mu* (at the
        reference load), ``mu * W_0 * (W / W_0)**m``, N: no load below zero (a finger
        pulled off the screen has none).

        Parameters
        ----------
        mu : array_like of float
            The coefficient at the reference load (:meth:`mu`).
        load_N : array_like of float, N
            The contact's load ``W = F_n + F_el`` (>= 0).

        Returns
        -------
        ndarray of float64, N
        """
        w = np.maximum(np.asarray(load_N, dtype=np.float64), 0.0)
        return self.load_law.friction(mu, w, floor=0.0)

    def coefficient_at(self, mu: npt.ArrayLike, load_N: npt.ArrayLike) -> FloatArray:
        """The coefficient ``F_t / W`` under *load_N*: ``mu * (W / W_0)**(m - 1)`` (*mu*
        where the load is zero).

        Parameters
        ----------
        mu : array_like of float
        load_N : array_like of float, N

        Returns
        -------
        ndarray of float64
        """
        mu_a = np.asarray(mu, dtype=np.float64)
        if self.exponent == 1.0:
            return np.asarray(np.broadcast_to(mu_a, np.broadcast_shapes(
                mu_a.shape, np.shape(load_N))), dtype=np.float64).copy()
        w = np.asarray(load_N, dtype=np.float64)
        # no load: the coefficient at W_0 (W_0 / W_0 is 1 to the last bit)
        at = np.where(w > 0, w, self.reference_load_N)
        return np.asarray(mu_a * self.load_law.coefficient_factor(at, floor=0.0),
                          dtype=np.float64)

    @property
    def constant(self) -> bool:
        """Whether ``mu`` is the same at every instant (the ideal finger)."""
        return self.moisture_rise == 0 and self.speed_exponent == 0 and self.asymmetry == 0

    def moisture(self, t_contact: npt.ArrayLike) -> FloatArray:
        """The moisture factor after *t_contact* seconds in contact."""
        tc = np.asarray(t_contact, dtype=np.float64)
        if self.moisture_rise == 0:
            return np.ones(tc.shape)
        return 1.0 - self.moisture_rise * np.expm1(-tc / self.moisture_time_s)

    def mu(self, t_contact: npt.ArrayLike, speed_m_s: npt.ArrayLike,
           direction: npt.ArrayLike) -> FloatArray:
        """The coefficient at each instant.

        Parameters
        ----------
        t_contact : array_like of float, s
            Time in contact so far (:func:`contact_time`).
        speed_m_s : array_like of float, m/s
            Speed of the stroke under way.
        direction : array_like of float
            Its direction (+1 / -1).

        Returns
        -------
        ndarray of float64
        """
        out = self.mu0 * self.moisture(t_contact)
        if self.speed_exponent:
            v = np.asarray(speed_m_s, dtype=np.float64)
            out = out * (v / self.reference_speed_m_s) ** self.speed_exponent
        if self.asymmetry:
            out = out * (1.0 + self.asymmetry * np.asarray(direction, dtype=np.float64))
        return np.asarray(out, dtype=np.float64)


#: Period of the press-and-release cycle of a calibration recording (``press_only``), s.
PRESS_PERIOD_S = 4.0


def press_cycle(t: FloatArray) -> FloatArray:
    """The factor on the target force of a finger pressing without sliding: 0.4 to 1.6 and
    back every :data:`PRESS_PERIOD_S`.

    Parameters
    ----------
    t : ndarray of float, s
        Times from the trial's start.

    Returns
    -------
    ndarray of float
    """
    return 1.0 - 0.6 * np.cos(2 * np.pi * np.asarray(t, dtype=np.float64) / PRESS_PERIOD_S)
