"""The rig: a CAN database and which of its signals are the forces and the excitation.

>>> rig = load_rig("acquisition/rigs/default.toml")        # doctest: +SKIP
>>> rig.normal_force.message.name, rig.normal_force.signal.name   # doctest: +SKIP
('FzCell', 'Fz')

A rig comes from a rig TOML (:func:`load_rig`), from the ``[rig]`` table of a study.toml
(:meth:`Rig.from_mapping`), or is the simulator's (:func:`default_rig`). Every role is
resolved against the DBC when the rig is built, so a wrong name fails before any log is read,
with a :class:`~evtribo.errors.RigConfigError` naming the key, the name and the closest
names the DBC has.

Keys of the table (docs/rig-file.md): ``dbc`` (path, relative to the TOML file),
``normal_force`` and ``tangential_force`` (required), the optional :data:`OPTIONAL_ROLES`
(counters, the amplifier's status and the command it obeys), each ``"Message.Signal"``;
``name`` (free text); the optional :data:`PERIOD_KEYS` (whole numbers: the frames after
which a cell's counter repeats, where its firmware does not count to its bit width's top);
and the optional sub-table ``calibration`` (``[rig.calibration]`` in study.toml,
:class:`Calibration`): the load cells' known zero offsets and cross-talk matrix. An unknown
key is an error (a misspelt optional role would otherwise be silently ignored); so is a
role that is not a string, or a period that is no whole number its counter's bits hold.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import json
import logging
import os
import re
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from cantools.database.can import Database, Message, Signal

from evtribo.canlog.dbc_file import parse_dbc
from evtribo.canlog.signal_codec import SignalCodec
from evtribo.documents.calibration import CALIBRATION_KEYS, Calibration
from evtribo.errors import RigConfigError, toml_problem
from evtribo.store.files import read_limited, sha256_file

log = logging.getLogger(__name__)

#: Roles a rig must name.
REQUIRED_ROLES = ("normal_force", "tangential_force")
#: Roles a rig may name.
OPTIONAL_ROLES = (
    "normal_force_counter",
    "tangential_force_counter",
    "excitation_enabled",
    "excitation_amplitude",
    "excitation_frequency",
    "excitation_waveform",
    "excitation_command_enabled",
    "excitation_command_amplitude",
    "excitation_command_frequency",
    "excitation_command_waveform",
)
ROLES = REQUIRED_ROLES + OPTIONAL_ROLES
#: The periods of the cells' counters, when the firmware's is not the bit width's (frames
#: after which the counter's value repeats: 100 for one counting 0 to 99 in 8 bits).
PERIOD_KEYS = ("normal_force_counter_period", "tangential_force_counter_period")
#: Keys of a rig table besides the roles.
OTHER_KEYS = ("name", "dbc", "calibration", *PERIOD_KEYS)

#: A signal named like a rolling frame counter (see :meth:`Rig.counter`).
COUNTER_NAME = re.compile(r"(counter|cnt)$", re.IGNORECASE)


@dataclass(frozen=True, repr=False)
class SignalRef:
    """A signal resolved in the DBC: its message and its definition."""

    message: Message
    signal: Signal

    def __repr__(self) -> str:
        return f"SignalRef({self.qualified_name!r})"

    @property
    def qualified_name(self) -> str:
        """``"Message.Signal"``."""
        return f"{self.message.name}.{self.signal.name}"


@dataclass(frozen=True)
class Rig:
    """A rig: its DBC and the signal each role maps to.

    Attributes
    ----------
    name : str
        Free text.
    dbc : Path
        The CAN database file.
    database : cantools.database.can.Database
        The parsed DBC.
    normal_force, tangential_force : SignalRef
        The load cells' force signals (N after DBC scaling).
    normal_force_counter, tangential_force_counter : SignalRef or None
        Rolling frame counters of the load cells, when they send one.
    excitation_enabled, excitation_amplitude, excitation_frequency, excitation_waveform :
        SignalRef or None
        The high-voltage amplifier's status (on/off, V, Hz, value table of waveforms).
    excitation_command_enabled, excitation_command_amplitude, excitation_command_frequency,
    excitation_command_waveform : SignalRef or None
        The command the amplifier obeys (``evtribo session`` sends it; the simulated rig
        obeys it).
    source : str or None
        The file the rig was read from (for messages).
    calibration : Calibration
        The load cells' known offsets and cross-talk matrix (empty when not given).
    normal_force_counter_period, tangential_force_counter_period : int or None
        Frames after which a cell's counter repeats, when the rig file declares it (None:
        its bit width's, or what its values show: :mod:`evtribo.canlog.counters.law`).
    """

    name: str
    dbc: Path
    database: Database = field(repr=False, compare=False)
    normal_force: SignalRef
    tangential_force: SignalRef
    normal_force_counter: SignalRef | None = None
    tangential_force_counter: SignalRef | None = None
    excitation_enabled: SignalRef | None = None
    excitation_amplitude: SignalRef | None = None
    excitation_frequency: SignalRef | None = None
    excitation_waveform: SignalRef | None = None
    excitation_command_enabled: SignalRef | None = None
    excitation_command_amplitude: SignalRef | None = None
    excitation_command_frequency: SignalRef | None = None
    excitation_command_waveform: SignalRef | None = None
    source: str | None = None
    calibration: Calibration = field(default_factory=Calibration)
    normal_force_counter_period: int | None = None
    tangential_force_counter_period: int | None = None

    @property
    def roles(self) -> dict[str, SignalRef]:
        """The roles this rig names, in :data:`ROLES` order."""
        refs = {r: getattr(self, r) for r in ROLES}
        return {r: ref for r, ref in refs.items() if ref is not None}

    @property
    def measured_roles(self) -> dict[str, SignalRef]:
        """The roles of what the rig reports (every role but the ``excitation_command_*``
        ones, which the rig obeys): what the decoder decodes."""
        return {r: ref for r, ref in self.roles.items() if "_command_" not in r}

    @property
    def has_excitation(self) -> bool:
        """Whether the rig broadcasts any of the amplifier's status signals."""
        return any(r.startswith("excitation_") and "_command_" not in r for r in self.roles)

    @property
    def has_command(self) -> bool:
        """Whether the amplifier obeys a command message the rig names."""
        return any("_command_" in r for r in self.roles)

    def counter(self, cell: str) -> SignalRef | None:
        """The rolling frame counter of a load cell (``"normal"`` or ``"tangential"``).

        The rig's ``<cell>_force_counter`` role when it names one; otherwise the first
        signal of the force's message named like a counter (``...Counter``, ``...Cnt``);
        otherwise None. The logger and the decoder both use this, so that they count lost
        frames with the same counter.
        """
        named = getattr(self, f"{cell}_force_counter")
        if named is not None:
            return named
        force: SignalRef = getattr(self, f"{cell}_force")
        for sig in force.message.signals:
            if COUNTER_NAME.search(sig.name) and sig is not force.signal:
                return SignalRef(message=force.message, signal=sig)
        return None

    def counter_period(self, cell: str) -> int | None:
        """The period the rig file declares for a load cell's counter (``"normal"`` or
        ``"tangential"``), frames; None when it declares none."""
        period: int | None = getattr(self, f"{cell}_force_counter_period")
        return period

    def fingerprint(self) -> str:
        """Hash of the DBC's bytes, the role mapping and the counters' periods (a cache key
        part)."""
        h = hashlib.sha256(sha256_file(self.dbc).encode())
        h.update(json.dumps({r: ref.qualified_name for r, ref in self.roles.items()},
                            sort_keys=True).encode())
        periods = {k: getattr(self, k) for k in PERIOD_KEYS if getattr(self, k) is not None}
        if periods:  # a rig without them keeps its fingerprint
            h.update(json.dumps(periods, sort_keys=True).encode())
        return h.hexdigest()

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any], base_dir: str | os.PathLike[str], *,
                     source: str | os.PathLike[str] | None = None,
                     key_prefix: str = "rig") -> Rig:
        """Build a rig from a table such as ``[rig]`` of study.toml.

        Parameters
        ----------
        mapping : mapping
            The table's keys (see the module docstring).
        base_dir : path-like
            Directory ``dbc`` is relative to (the TOML file's).
        source : path-like, optional
            The file the table comes from, named in errors.
        key_prefix : str
            Prefix of the keys in errors (``rig`` gives ``rig.normal_force``; ``""`` for a
            rig TOML, where the keys are top-level).

        Raises
        ------
        RigConfigError
            Unknown or missing key, DBC missing or unparsable, a malformed ``Message.Signal``
            or one the DBC lacks.
        """
        src = None if source is None else os.fspath(source)

        def key(k: str) -> str:
            return f"{key_prefix}.{k}" if key_prefix else k

        unknown = sorted(set(mapping) - set(ROLES) - set(OTHER_KEYS))
        if unknown:
            hints = []
            for k in unknown:
                close = difflib.get_close_matches(k, ROLES + OTHER_KEYS, n=1)
                hints.append(f"{k!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))
            raise RigConfigError(
                "unknown key(s) " + ", ".join(hints) + "; allowed: "
                + ", ".join(OTHER_KEYS + ROLES), path=src, key=key(unknown[0]))
        for k in ("dbc", *REQUIRED_ROLES):
            if k not in mapping:
                raise RigConfigError("missing (required)", path=src, key=key(k))
        for k, v in mapping.items():
            if not isinstance(v, str) and k not in ("calibration", *PERIOD_KEYS):
                raise RigConfigError(f"must be a string, got {type(v).__name__} {v!r}",
                                     path=src, key=key(k))
        dbc = Path(base_dir) / mapping["dbc"]
        db = load_dbc(dbc, source=src, key=key("dbc"))  # checked: a DBC, not echoed
        refs = {r: resolve_signal(db, mapping[r], key=key(r), source=src)
                for r in ROLES if r in mapping}
        for r, ref in refs.items():  # cantools decodes no frame of such a message
            beyond = [s.name for s in ref.message.signals
                      if SignalCodec.from_signal(s).last_byte() >= ref.message.length]
            if beyond:
                raise RigConfigError(f"message {ref.message.name}'s signal {beyond[0]} lies "
                                     f"beyond its {ref.message.length} bytes: no frame of it "
                                     f"can be decoded; fix the DBC {dbc}", path=src, key=key(r))
        _check_distinct(refs, source=src, key=key)
        calibration = Calibration()
        if "calibration" in mapping:
            calibration = Calibration.from_mapping(mapping["calibration"], source=src,
                                                   key=key("calibration"))
        rig = cls(name=str(mapping.get("name", dbc.stem)), dbc=dbc.resolve(), database=db,
                  source=src, calibration=calibration, **refs)  # type: ignore[arg-type]
        normal, tangential = (_period(rig, k, mapping[k], source=src, key=key(k))
                              if k in mapping else None for k in PERIOD_KEYS)
        if normal is None and tangential is None:
            return rig
        return dataclasses.replace(rig, normal_force_counter_period=normal,
                                   tangential_force_counter_period=tangential)


def _period(rig: Rig, name: str, value: object, *, source: str | None, key: str) -> int:
    """A declared counter period: a whole number of frames, 2 up to the values its counter's
    bits hold."""
    cell = name.removesuffix("_force_counter_period")
    counter = rig.counter(cell)
    if counter is None:
        message = getattr(rig, f"{cell}_force").message.name
        raise RigConfigError(f"the {cell} force's message {message} has no counter: name one "
                             f"({cell}_force_counter) or leave the key out", path=source, key=key)
    most = 1 << counter.signal.length
    if isinstance(value, bool) or not isinstance(value, int) or not 2 <= value <= most:
        raise RigConfigError(
            f"expected the frames after which {counter.qualified_name} repeats, a whole "
            f"number from 2 to {most} (its {counter.signal.length} bits), got {value!r}",
            path=source, key=key)
    return value


def _check_distinct(refs: Mapping[str, SignalRef], *, source: str | None,
                    key: Callable[[str], str]) -> None:
    """Refuse one signal named for two roles (the counters aside: cells sharing a message
    share its counter)."""
    seen: dict[tuple[int, bool, str], str] = {}
    for role, ref in refs.items():
        if role.endswith("_counter"):
            continue
        ident = (ref.message.frame_id, bool(ref.message.is_extended_frame), ref.signal.name)
        if ident in seen:
            raise RigConfigError(
                f"{ref.qualified_name} is named for two roles, {seen[ident]} and {role}: each "
                "role needs a signal of its own (evtribo init guesses them from the DBC and a "
                "sample log)", path=source, key=key(role))
        seen[ident] = role


def load_dbc(path: str | os.PathLike[str], *, source: str | None = None,
             key: str | None = None) -> Database:
    """Parse a DBC with cantools (:func:`evtribo.canlog.dbc_file.parse_dbc`).

    A DBC whose signals overlap or overrun their message (cantools' strict checks) is still
    loaded, with a warning: vendors' DBCs often have such quirks, and each signal is decoded
    on its own. A file that is not a DBC is refused by name, its content never shown.

    Parameters
    ----------
    path : path-like
        The DBC.
    source, key : str, optional
        The file and key that named it, for messages.

    Returns
    -------
    cantools.database.can.Database

    Raises
    ------
    RigConfigError
        The file is missing, not a DBC, or does not parse (naming *source* and *key*).
    """
    return parse_dbc(path, source=source, key=key)


def resolve_signal(db: Database, qualified: str, *, key: str, source: str | None = None
                   ) -> SignalRef:
    """Find ``"Message.Signal"`` in *db*.

    Parameters
    ----------
    db : cantools.database.can.Database
    qualified : str
        ``"Message.Signal"``.
    key : str
        The key that names it, for messages.
    source : str, optional
        The file of that key.

    Returns
    -------
    SignalRef

    Raises
    ------
    RigConfigError
        Malformed name, or a message or signal the DBC lacks (with the closest names).
    """
    parts = qualified.split(".")
    if len(parts) != 2 or not all(p.strip() for p in parts):
        raise RigConfigError(f"{qualified!r} is not of the form 'Message.Signal'",
                             path=source, key=key)
    msg_name, sig_name = (p.strip() for p in parts)
    names = [m.name for m in db.messages]
    try:
        message = db.get_message_by_name(msg_name)
    except KeyError:
        close = difflib.get_close_matches(msg_name, names, n=3, cutoff=0.4)
        raise RigConfigError(
            f"message {msg_name!r} is not in the DBC; "
            + (f"closest: {', '.join(close)}" if close else f"it has: {', '.join(names)}"),
            path=source, key=key) from None
    sig_names = [s.name for s in message.signals]
    if sig_name not in sig_names:
        close = difflib.get_close_matches(sig_name, sig_names, n=3, cutoff=0.4)
        others = [f"{m.name}.{s.name}" for m in db.messages for s in m.signals
                  if s.name == sig_name]
        hint = f"closest: {', '.join(close)}" if close else f"it has: {', '.join(sig_names)}"
        if others:
            hint += f"; {sig_name!r} is in {', '.join(others)}"
        raise RigConfigError(f"message {msg_name!r} has no signal {sig_name!r}; {hint}",
                             path=source, key=key)
    return SignalRef(message=message, signal=message.get_signal_by_name(sig_name))


def load_rig(toml_path: str | os.PathLike[str]) -> Rig:
    """Read a rig TOML (keys at the top level, ``dbc`` relative to the file).

    Parameters
    ----------
    toml_path : path-like
        The rig TOML.

    Returns
    -------
    Rig

    Raises
    ------
    RigConfigError
        The file is missing, a folder, unreadable, not UTF-8 or not TOML, or
        :meth:`Rig.from_mapping` refuses it.
    """
    path = Path(toml_path)
    text = ""
    try:
        text = read_limited(path, RigConfigError, what="rig TOML file").decode("utf-8")
        table = tomllib.loads(text)
    except FileNotFoundError as err:
        raise RigConfigError("rig file not found", path=path) from err
    except RecursionError as err:
        raise RigConfigError("not valid TOML: nested too deeply", path=path) from err
    except OSError as err:  # permission denied, I/O error...
        raise RigConfigError(f"cannot read the rig file: {err.strerror or err}",
                             path=path) from err
    except UnicodeDecodeError as err:
        raise RigConfigError(f"not UTF-8 text: {err.reason} at byte {err.start}",
                             path=path) from err
    except tomllib.TOMLDecodeError as err:
        reason, line, key = toml_problem(err, text)
        raise RigConfigError(f"not valid TOML: {reason}", path=path, line=line, key=key) \
            from err
    if "rig" in table and isinstance(table["rig"], dict):
        return Rig.from_mapping(table["rig"], path.parent, source=path, key_prefix="rig")
    return Rig.from_mapping(table, path.parent, source=path, key_prefix="")


def default_rig_path() -> Path:
    """The simulator's rig TOML (package data ``evtribo/data/rigs/default.toml``).

    Returns
    -------
    Path
    """
    return Path(str(resources.files("evtribo") / "data" / "rigs" / "default.toml"))


def default_rig() -> Rig:
    """The simulator's rig: ``FzCell.Fz``, ``FxCell.Fx``, their counters and ``HvStatus``.

    Returns
    -------
    Rig
    """
    return load_rig(default_rig_path())


__all__ = ["CALIBRATION_KEYS", "PERIOD_KEYS", "ROLES", "Calibration", "Rig", "SignalRef",
           "default_rig", "default_rig_path", "load_dbc", "load_rig", "resolve_signal"]
