"""The simulated rig: the default rig's frames from the seed paper's model.

:func:`simulate_trial` gives one trial's frames offline (a :class:`~evtribo.canlog.io.FrameTable`)
with the truth the analysis must recover; :func:`simulate_study` writes a whole study folder;
:class:`Simulator` streams the same frames in real time on a python-can bus or an slcan pty.
"""

from evtribo.acquisition.simulator.config import (
    CONDITIONS,
    WAVEFORMS,
    SubjectParams,
    TrialConfig,
)
from evtribo.acquisition.simulator.core import (
    DEFAULT_DBC,
    TrialGenerator,
    TrialTruth,
    simulate_trial,
)
from evtribo.acquisition.simulator.realtime import RunStats, Simulator
from evtribo.acquisition.simulator.study import (
    SubjectPopulation,
    default_subjects,
    population_subjects,
    simulate_study,
    write_trial,
)

__all__ = [
    "CONDITIONS",
    "DEFAULT_DBC",
    "WAVEFORMS",
    "RunStats",
    "Simulator",
    "SubjectParams",
    "SubjectPopulation",
    "TrialConfig",
    "TrialGenerator",
    "TrialTruth",
    "default_subjects",
    "population_subjects",
    "simulate_study",
    "simulate_trial",
    "write_trial",
]
