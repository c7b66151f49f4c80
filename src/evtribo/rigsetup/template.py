"""A new study for a lab's own rig: ``study.toml`` with every key, the DBC beside it.

:func:`render_study_toml` writes the text: the roles guessed (each with its reason in a
comment, ``CHECK`` where uncertain), the optional keys commented out with their meaning, the
``[rig.calibration]`` and ``[analysis]`` tables commented out with their defaults.
:func:`init_study` creates the folder (``evtribo init``).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from cantools.database.can import Database

from evtribo import __version__
from evtribo.analysis.settings import SETTING_HELP, AnalysisSettings
from evtribo.canlog.io import FrameTable, read_frames
from evtribo.canlog.io.ids import frame_key, frame_keys, id_text, key_id
from evtribo.canlog.rig import load_dbc
from evtribo.errors import FORCE, OutputExistsError, RigConfigError
from evtribo.rigsetup.roles import RoleGuess, guess_roles
from evtribo.rigsetup.stats import signal_stats
from evtribo.store.files import atomic_write
from evtribo.store.owned import claim, refuse_foreign

__all__ = ["ROLE_HELP", "InitResult", "init_study", "render_study_toml"]

#: What each role of ``[rig]`` means (the comment above its line).
ROLE_HELP = {
    "normal_force": "the normal load cell: force pressing the finger on the screen, N after "
                    "DBC scaling",
    "tangential_force": "the tangential load cell: friction force, N; its sign follows the "
                        "sliding direction",
    "normal_force_counter": "optional: the normal cell's rolling frame counter (lost frames)",
    "tangential_force_counter": "optional: the tangential cell's rolling frame counter",
    "excitation_enabled": "optional: the amplifier's status, 0 = off, 1 = on",
    "excitation_amplitude": "optional: the amplifier's status, amplitude of the applied "
                            "voltage, V",
    "excitation_frequency": "optional: the amplifier's status, frequency, Hz",
    "excitation_waveform": "optional: the amplifier's status, waveform (value table: sine / "
                           "square)",
    "excitation_command_enabled": "optional: the command the amplifier obeys, on/off "
                                  "(evtribo session sends it)",
    "excitation_command_amplitude": "optional: the command, amplitude, V",
    "excitation_command_frequency": "optional: the command, frequency, Hz",
    "excitation_command_waveform": "optional: the command, waveform (value table)",
}
_REQUIRED = ("normal_force", "tangential_force")


def _toml_value(value: object) -> str:
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _role_lines(guess: RoleGuess) -> list[str]:
    lines = [f"# {ROLE_HELP[guess.role]}"]
    if guess.name is None:
        lines.append(f"# not guessed: {guess.reason}")
        lines.append(f'# {guess.role} = "Message.Signal"')
        return lines
    check = "" if guess.certain else "CHECK: "
    lines.append(f"# {check}guessed: {guess.reason}")
    lines.append(f"{guess.role} = {json.dumps(guess.name)}")
    return lines


def render_study_toml(name: str, dbc: str, guesses: Mapping[str, RoleGuess], *,
                      source: str = "") -> str:
    """The text of a new study's ``study.toml``.

    Parameters
    ----------
    name : str
        The study's name (free text).
    dbc : str
        The DBC's path relative to the study folder (``rig/loadcells.dbc``).
    guesses : mapping of str to RoleGuess
        :func:`~evtribo.rigsetup.guess_roles`'s answer.
    source : str
        What the guesses came from, for the header (``"rig.dbc and run-01.log"``).

    Returns
    -------
    str
        TOML text that :func:`evtribo.study.load_study` reads once the required roles are
        there.
    """
    out = [f"# A study of evtribo {__version__} (spec: docs/study-format.md), written by "
           "`evtribo init`" + (f" from {source}" if source else "") + ".",
           "# The roles below were guessed: check each (`evtribo inspect LOG --dbc "
           f"{dbc}` shows", "# what every signal does in a log), then record with "
           "`evtribo acquire` or `evtribo session`.", "",
           f"name = {json.dumps(name)}", "", "[rig]",
           "# the CAN database describing the rig's messages (relative to this file)",
           f"dbc = {json.dumps(dbc)}"]
    for guess in guesses.values():
        out.append("")
        out += _role_lines(guess)
    out += ["", "# the load cells' own calibration, applied after DBC scaling:",
            "# [Fn, Ft]_true = matrix @ ([Fn, Ft]_measured - offsets); omit the offsets to "
            "let the analysis tare", "# [rig.calibration]", "# normal_offset_N = 0.0",
            "# tangential_offset_N = 0.0", "# matrix = [[1.0, 0.0], [0.0, 1.0]]", "",
            "# the analysis's settings, with their defaults (uncomment to change one)",
            "# [analysis]"]
    defaults = AnalysisSettings()
    for f in fields(AnalysisSettings):
        out.append(f"# {f.name} = {_toml_value(getattr(defaults, f.name))}")
        if f.name in SETTING_HELP:
            out[-1] += f"    # {SETTING_HELP[f.name]}"
    return "\n".join(out) + "\n"


@dataclass(frozen=True)
class InitResult:
    """What :func:`init_study` made.

    Attributes
    ----------
    study_toml : Path
    dbc : Path
        The copy of the DBC in the study folder.
    guesses : dict of str to RoleGuess
    """

    study_toml: Path
    dbc: Path
    guesses: dict[str, RoleGuess]

    @property
    def missing(self) -> list[str]:
        """Required roles left unguessed."""
        return [r for r in _REQUIRED if self.guesses[r].name is None]


def _refuse_a_log_of_another_rig(frames: FrameTable, db: Database, log: Path,
                                 dbc: Path) -> None:
    """Refuse a sample log none of whose identifiers is a message of the DBC: the two are
    not of one rig, and nothing could be guessed from it."""
    data = ~frames.is_error
    keys = np.unique(frame_keys(frames.arbitration_id[data], frames.is_extended[data]))
    known = {frame_key(m.frame_id, bool(m.is_extended_frame)): m.name for m in db.messages}
    if keys.size == 0 or any(int(k) in known for k in keys):
        return
    shown = ", ".join(f"0x{id_text(*key_id(int(k)))}" for k in keys[:8])
    more = f" and {keys.size - 8} more" if keys.size > 8 else ""
    messages = ", ".join(f"{name} (0x{id_text(*key_id(k))})" for k, name in
                         list(known.items())[:8]) or "none"
    raise RigConfigError(
        f"none of the log's {keys.size} identifiers ({shown}{more}) is a message of the DBC "
        f"{dbc} (its messages: {messages}): the log and the DBC are not of one rig; give "
        "the rig's DBC, or a log recorded from that rig (`evtribo inspect LOG` lists a "
        "log's identifiers)", path=os.fspath(log), key="--log")


def init_study(study: str | os.PathLike[str], dbc: str | os.PathLike[str], *,
               log: str | os.PathLike[str] | None = None, force: bool = False,
               strict: bool = False) -> InitResult:
    """Create a study folder for a rig: ``STUDY/study.toml`` and ``STUDY/rig/<dbc>``.

    Parameters
    ----------
    study : path-like
        The study folder (created if needed).
    dbc : path-like
        The rig's DBC.
    log : path-like, optional
        A sample log of the rig (a few seconds of sliding, any format evtribo reads): the
        signals' behaviour then guides the guesses.
    force : bool
        Replace an existing study.toml (the DBC copy too).
    strict : bool
        A damaged line of the sample log is an error.

    Returns
    -------
    InitResult

    Raises
    ------
    OutputExistsError
        STUDY already has a study.toml and *force* is False; or, *force* or not, one (or a
        DBC of the same name in ``rig/``) that init did not write.
    RigConfigError
        The DBC is missing or unreadable, or none of the sample log's identifiers is a
        message of it.
    """
    folder = Path(study)
    toml = folder / "study.toml"
    if toml.exists() and not force:
        raise OutputExistsError(f"already has a study.toml; {FORCE} replaces it", path=folder)
    # --force replaces a study.toml init wrote, never one a user wrote or edited
    refuse_foreign(folder, ["study.toml"], {"init"})
    src = Path(dbc)
    try:
        src.stat()
    except FileNotFoundError:
        raise RigConfigError("DBC file not found", path=os.fspath(src)) from None
    except OSError as err:  # in a folder the user may not enter
        raise RigConfigError(f"cannot read: {err.strerror}", path=os.fspath(src)) from None
    copy = folder / "rig" / src.name
    if copy.exists() and copy.resolve() != src.resolve() and \
            copy.read_bytes() != src.read_bytes():
        refuse_foreign(copy.parent, [copy.name], {"init"})  # another DBC of that name
    db = load_dbc(src, source=os.fspath(src))
    stats = None
    if log is not None:
        frames, _ = read_frames(log, strict=strict)
        _refuse_a_log_of_another_rig(frames, db, Path(log), src)
        stats = signal_stats(frames, db)
    guesses = guess_roles(db, stats)
    copy.parent.mkdir(parents=True, exist_ok=True)
    if copy.resolve() != src.resolve():
        atomic_write(copy, src.read_bytes())
        claim(copy, "init")
    source = src.name + (f" and {Path(log).name}" if log is not None else "")
    text = render_study_toml(folder.resolve().name, f"rig/{src.name}", guesses, source=source)
    atomic_write(toml, text)
    claim(toml, "init")
    return InitResult(study_toml=toml, dbc=copy, guesses=guesses)

