"""Setting up a lab's own rig: what a log's signals do, which of them is which role, and a
study folder scaffolded from a DBC (``evtribo init``, ``evtribo inspect --dbc``).

- :mod:`.stats`: per message and signal of a log decoded with a DBC, the rate and
  min / mean / max, and how the signal behaves (steady, changing sign, switching, counting).
- :mod:`.roles`: the rig's roles (spec §1) guessed from the DBC's names, units and value
  tables and, with a sample log, from the signals' behaviour; each guess with its reason.
- :mod:`.template`: ``study.toml`` with every key, the guesses filled in, the optional keys
  commented with their meaning.
"""

from evtribo.rigsetup.roles import RoleGuess, behaviour_text, guess_roles
from evtribo.rigsetup.stats import SignalStats, signal_stats
from evtribo.rigsetup.template import init_study, render_study_toml

__all__ = ["RoleGuess", "SignalStats", "behaviour_text", "guess_roles", "init_study",
           "render_study_toml", "signal_stats"]
