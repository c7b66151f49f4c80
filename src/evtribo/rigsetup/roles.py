"""Which signal of a DBC is which role of the rig (spec §1), guessed with reasons.

From the DBC alone the names (``Fz``, ``NormalCell``, ``HvOn``...), units (N, V, Hz), bit
widths and value tables (``sine`` / ``square``) speak; with a sample log the signals'
behaviour speaks too (:mod:`~evtribo.rigsetup.stats`): the normal force is positive and steady, the
tangential force changes sign with the strokes, a status signal switches, a counter counts.
Behaviour outweighs names, so a rig whose cells are named ``Ch1`` and ``Ch2`` is told apart
from a log. Every guess carries its reason, and says when it is uncertain.

Messages named like commands (``HvCmd``, ``AmpSet``, ``...Control``, ``...Request``) hold
the ``excitation_command_*`` roles (what the amplifier obeys); the others the status roles
(what it reports).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from cantools.database.can import Database, Message, Signal

from evtribo.rigsetup.stats import SignalStats

__all__ = ["COMMAND_ROLES", "STATUS_ROLES", "RoleGuess", "behaviour_text", "guess_roles", "tokens"]

#: The amplifier's status roles (what it reports).
STATUS_ROLES = ("excitation_enabled", "excitation_amplitude", "excitation_frequency",
                "excitation_waveform")
#: The amplifier's command roles (what it obeys).
COMMAND_ROLES = tuple(r.replace("excitation_", "excitation_command_") for r in STATUS_ROLES)

_NORMAL = {"fz", "fn", "normal", "norm", "load", "press", "pressing", "vertical"}
_TANGENTIAL = {"fx", "fy", "ft", "ff", "tangential", "tang", "friction", "fric", "shear",
               "lateral", "drag"}
_COUNTER = {"counter", "cnt", "ctr", "seq", "sequence", "alive", "rolling", "rc"}
_ENABLED = {"on", "enable", "enabled", "active", "out", "output", "state", "run", "hvon"}
_AMPLITUDE = {"amp", "amplitude", "volt", "volts", "voltage", "vpp", "level", "ampl", "u"}
_FREQUENCY = {"freq", "frequency", "hz", "hertz", "f"}
_WAVEFORM = {"wave", "waveform", "shape", "form", "wf"}
_WAVE_NAMES = {"sine", "sin", "square", "sq", "triangle", "tri", "dc"}
_COMMAND = {"cmd", "command", "set", "setpoint", "ctrl", "control", "req", "request",
            "demand"}
_FORCE_UNITS = {"n", "mn", "kn", "g", "kg", "gf", "kgf", "lbf"}
_VOLT_UNITS = {"v", "kv", "mv", "vpp"}
_HZ_UNITS = {"hz", "khz"}
#: A guess with less than this score is not made.
MIN_SCORE = 3.0
#: A pair of forces whose score beats the next pair by less than this is uncertain.
MARGIN = 2.0


def tokens(name: str) -> list[str]:
    """The words of a CamelCase or snake_case name, lower case.

    Parameters
    ----------
    name : str
        ``"HvOn"``, ``"Force_mN"``...

    Returns
    -------
    list of str
        ``["hv", "on"]``, ``["force", "m", "n"]``...
    """
    return [w.lower() for w in re.findall(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])|\d+", name)]


def _meaning(name: str) -> set[str]:
    """The words of *name* that may say a role: a "load cell" names the sensor, not the
    load it measures (``LoadCell1`` says nothing of normal force)."""
    words = tokens(name)
    return {w for i, w in enumerate(words)
            if not (w == "load" and words[i + 1:i + 2] in (["cell"], ["cells"]))}


@dataclass(frozen=True)
class RoleGuess:
    """One role of the rig and the signal guessed for it.

    Attributes
    ----------
    role : str
        A key of spec §1 (``normal_force``, ``excitation_command_amplitude``...).
    name : str or None
        ``"Message.Signal"``, or None when no signal fits.
    reason : str
        Why (or why none).
    certain : bool
        False when another signal fits almost as well: the user should check.
    """

    role: str
    name: str | None
    reason: str
    certain: bool = True


@dataclass(frozen=True)
class _Candidate:
    message: Message
    signal: Signal
    stats: SignalStats | None

    @property
    def name(self) -> str:
        return f"{self.message.name}.{self.signal.name}"

    @property
    def words(self) -> set[str]:
        return _meaning(self.signal.name)

    @property
    def message_words(self) -> set[str]:
        return _meaning(self.message.name)

    @property
    def unit(self) -> str:
        return (self.signal.unit or "").strip().lower()

    @property
    def is_command(self) -> bool:
        return bool(self.message_words & _COMMAND)


Score = tuple[float, list[str]]


def _hint(c: _Candidate, words: set[str], what: str) -> Score:
    """Points for a name that says *what* (the signal's name counts more than its
    message's)."""
    if c.words & words:
        return 3.0, [f"its name says {what} ({c.signal.name})"]
    if c.message_words & words:
        return 2.0, [f"its message's name says {what} ({c.message.name})"]
    return 0.0, []


def _continuous(c: _Candidate) -> Score | None:
    """None when the log shows the signal is not a continuous measurement."""
    if c.stats is not None and c.stats.behaviour != "continuous":
        return None
    if c.signal.length < 8 or c.signal.choices:
        return None
    return 0.0, []


def _force(c: _Candidate, words: set[str], what: str, behaves: Callable[[SignalStats], Score]
           ) -> Score | None:
    base = _continuous(c)
    if base is None:
        return None
    score, why = _hint(c, words, what)
    if c.unit in _FORCE_UNITS:
        score += 2.0
        why.append(f"unit {c.signal.unit}")
    if c.stats is not None:
        s, w = behaves(c.stats)
        score += s
        why += w
    return score, why


def _normal_behaviour(s: SignalStats) -> Score:
    text = (f"positive {100 * s.positive_fraction:.0f} % of the time, mean {s.mean:.3g}, "
            f"{s.sign_changes_per_s:.2f} changes of sign/s")
    if s.positive_fraction >= 0.8 and s.sign_changes_per_s < 0.2:
        return 5.0, [f"in the log positive and steady ({text})"]
    return -3.0, [f"in the log not steady ({text})"]


def _tangential_behaviour(s: SignalStats) -> Score:
    text = (f"{s.sign_changes_per_s:.2f} changes of sign/s, positive "
            f"{100 * s.positive_fraction:.0f} % of the time")
    if s.sign_changes_per_s >= 0.2 and 0.1 <= s.positive_fraction <= 0.9:
        return 5.0, [f"in the log changes sign with the strokes ({text})"]
    return -3.0, [f"in the log does not change sign with strokes ({text})"]


def _counter(c: _Candidate) -> Score | None:
    sig = c.signal
    if sig.is_signed or sig.is_float or sig.scale != 1 or sig.offset != 0:
        return None
    score, why = (3.0, [f"its name says counter ({sig.name})"]) if c.words & _COUNTER \
        else (0.0, [])
    if c.stats is not None:
        if c.stats.behaviour == "counter":
            score += 5.0
            why.append(f"in the log it counts up by one "
                       f"({100 * c.stats.counting_fraction:.0f} % of frames)")
        else:
            return None
    return score, why



def _enabled(c: _Candidate) -> Score | None:
    sig = c.signal
    choices = {str(v).lower() for v in (sig.choices or {}).values()}
    if sig.length > 2 and not choices & {"on", "off", "enabled", "disabled"}:
        return None
    score, why = _hint(c, _ENABLED, "on/off")
    if sig.length == 1:
        score += 1.0
        why.append("one bit")
    if choices & {"on", "off", "enabled", "disabled"}:
        score += 2.0
        why.append("its value table says on/off")
    if c.stats is not None and c.stats.switches > 0:
        score += 2.0
        why.append(f"in the log it switches ({c.stats.switches} times)")
    return score, why


def _unit_role(units: set[str], words: set[str], what: str) -> Callable[[_Candidate],
                                                                        Score | None]:
    def score(c: _Candidate) -> Score | None:
        if c.signal.choices or c.signal.length < 4:
            return None
        s, why = _hint(c, words, what)
        if c.unit in units:
            s += 3.0
            why.append(f"unit {c.signal.unit}")
        return s, why
    return score


def _waveform(c: _Candidate) -> Score | None:
    names = [str(v) for v in (c.signal.choices or {}).values()]
    score, why = _hint(c, _WAVEFORM, "waveform")
    if {n.lower() for n in names} & _WAVE_NAMES:
        score += 5.0
        why.append("its value table names waveforms (" + ", ".join(names) + ")")
    elif c.signal.length > 4:
        return None
    return score, why


_EXCITATION: dict[str, Callable[[_Candidate], Score | None]] = {
    "enabled": _enabled,
    "amplitude": _unit_role(_VOLT_UNITS, _AMPLITUDE, "amplitude"),
    "frequency": _unit_role(_HZ_UNITS, _FREQUENCY, "frequency"),
    "waveform": _waveform,
}


def _candidates(db: Database, stats: Mapping[str, SignalStats] | None) -> list[_Candidate]:
    out = []
    for message in db.messages:
        for signal in message.signals:
            if signal.is_multiplexer:
                continue
            s = None if stats is None else stats.get(f"{message.name}.{signal.name}")
            commanded = bool(set(tokens(message.name)) & _COMMAND)
            if stats is not None and s is None and not commanded:
                continue  # the log has no frame of this message: its behaviour is unknown
            out.append(_Candidate(message, signal, s))
    return out


def _reason(why: list[str]) -> str:
    return "; ".join(why) if why else "no other signal fits"


def _forces(cands: list[_Candidate]) -> tuple[RoleGuess, RoleGuess, _Candidate | None,
                                               _Candidate | None]:
    """The best pair (normal, tangential) of distinct continuous signals."""
    normal = {c.name: _force(c, _NORMAL, "normal force", _normal_behaviour) for c in cands}
    tang = {c.name: _force(c, _TANGENTIAL, "tangential force", _tangential_behaviour)
            for c in cands}
    pairs: list[tuple[float, _Candidate, _Candidate]] = []
    for a in cands:
        sa = normal[a.name]
        if sa is None:
            continue
        for b in cands:
            sb = tang[b.name]
            if sb is None or b.name == a.name:
                continue
            pairs.append((sa[0] + sb[0], a, b))
    if not pairs:
        none = "no continuous signal of 8 bits or more"
        return (RoleGuess("normal_force", None, none, False),
                RoleGuess("tangential_force", None, none, False), None, None)
    pairs.sort(key=lambda p: -p[0])
    best, a, b = pairs[0]
    rivals = [p for p in pairs[1:] if p[1] is not a or p[2] is not b]
    certain = not rivals or best - rivals[0][0] >= MARGIN
    sa, sb = normal[a.name], tang[b.name]
    assert sa is not None and sb is not None
    note = "" if certain else " (uncertain: another signal fits almost as well; a sample " \
        "log with --log tells them apart)"
    return (RoleGuess("normal_force", a.name, _reason(sa[1]) + note, certain),
            RoleGuess("tangential_force", b.name, _reason(sb[1]) + note, certain), a, b)


def _best(cands: list[_Candidate], score: Callable[[_Candidate], Score | None], role: str,
          taken: set[str], bonus_message: str | None = None) -> tuple[RoleGuess,
                                                                     _Candidate | None]:
    scored = []
    for c in cands:
        if c.name in taken:
            continue
        s = score(c)
        if s is None:
            continue
        total, why = s
        if bonus_message is not None and c.message.name == bonus_message:
            total += 1.0
        scored.append((total, c, why))
    scored.sort(key=lambda x: -x[0])
    if not scored or scored[0][0] < MIN_SCORE:
        return RoleGuess(role, None, "no signal fits"), None
    total, c, why = scored[0]
    certain = len(scored) < 2 or total - scored[1][0] >= 1.0
    return RoleGuess(role, c.name, _reason(why), certain), c


def guess_roles(db: Database, stats: Mapping[str, SignalStats] | None = None
                ) -> dict[str, RoleGuess]:
    """Guess every role of spec §1 from a DBC and, optionally, a sample log's statistics.

    Parameters
    ----------
    db : cantools Database
        The rig's DBC.
    stats : mapping of str to SignalStats, optional
        :func:`evtribo.rigsetup.signal_stats` of a sample log: with it, only signals the log
        carries are considered, and their behaviour outweighs their names.

    Returns
    -------
    dict of str to RoleGuess
        One per role, in the order of spec §1 (``normal_force``, ``tangential_force``, the
        counters, the status roles, the command roles); ``name`` is None where nothing fits.
    """
    cands = _candidates(db, stats)
    normal, tangential, a, b = _forces(cands)
    out = {"normal_force": normal, "tangential_force": tangential}
    taken = {g.name for g in out.values() if g.name}
    for cell, force in (("normal", a), ("tangential", b)):
        role = f"{cell}_force_counter"
        same = [c for c in cands if force is not None and c.message is force.message]
        out[role], _ = _best(same, _counter, role, taken)
    for roles, command in ((STATUS_ROLES, False), (COMMAND_ROLES, True)):
        pool = [c for c in cands if c.is_command == command]
        anchor: str | None = None
        for role in roles:
            guess, c = _best(pool, _EXCITATION[role.rsplit("_", 1)[1]], role, taken,
                             bonus_message=anchor)
            out[role] = guess
            if c is not None:
                taken.add(c.name)
                anchor = anchor or c.message.name
    return out


def behaviour_text(s: SignalStats) -> str:
    """A short description of how a signal behaves in a log (for ``inspect``).

    Parameters
    ----------
    s : SignalStats

    Returns
    -------
    str
        ``"positive, steady"``, ``"changes sign 0.8/s"``, ``"counter"``, ``"switching"``...
    """
    if s.behaviour == "continuous":
        if not math.isnan(s.sign_changes_per_s) and s.sign_changes_per_s >= 0.2:
            return f"changes sign {s.sign_changes_per_s:.2g}/s"
        if s.positive_fraction >= 0.8:
            return "positive, steady"
        return "continuous"
    return s.behaviour
