"""A subject's whole protocol in one command (``evtribo session``, spec §7).

- :mod:`.check`: the short check of a trial just recorded (forces present, windows found,
  frames dropped), by the analysis itself.
- :mod:`.runner`: the session: the plan in ``session.json``, one trial after another with the
  excitation set by command or by the operator, the check and the choice to redo, pauses,
  Ctrl-C keeping every finished trial, and a re-run that goes on where it stopped.
"""

from evtribo.session.check import TrialCheck, check_trial
from evtribo.session.runner import SessionConfig, SessionOutcome, run_session

__all__ = ["SessionConfig", "SessionOutcome", "TrialCheck", "check_trial", "run_session"]
