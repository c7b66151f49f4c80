"""``evtribo session``: a subject's protocol, one trial after another (spec §7).

The plan (the protocol's trials, expanded, repeated, shuffled with a recorded seed) is written
to ``STUDY/SUBJECT/session.json`` before the first trial; trials are named ``run-01``,
``run-02``, ... in the order recorded (after any the subject already has). For each trial:

1. the excitation is set: through the rig's command message (``excitation_command_*``), kept
   sent while the trial records (an alternating trial's ON/OFF phases after the tare
   stretch), or by asking the operator to set the amplifier;
2. the trial records like ``evtribo acquire`` (the tare stretch first, the live display and
   view), into a normal trial of the study (log + sidecar);
3. the analysis checks it (forces present, windows found, frames dropped) and the operator
   keeps it or redoes it (the first recording is kept under ``SUBJECT/rejected/``);
4. ``session.json`` records it done; a pause follows.

Ctrl-C stops the session and keeps every finished trial; a trial it cut short goes to
``rejected/``. Running the same command again continues with the first trial not done:
nothing recorded is ever recorded again, nor lost.
"""

from __future__ import annotations

import logging
import sys
import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, TextIO

import can

from evtribo.acquisition.buses.bus import BusSettings
from evtribo.acquisition.command import Excitation, ExcitationCommand
from evtribo.acquisition.live.liveview import LiveView
from evtribo.acquisition.live.monitor import Monitor
from evtribo.acquisition.protocol import (
    Protocol,
    SessionSettings,
    plan_trials,
    read_protocol,
    session_seed,
)
from evtribo.acquisition.rigfile import AcquisitionRig, check_name, open_study
from evtribo.acquisition.trial import record_trial
from evtribo.acquisition.trialdata import RIG_DATA_TIMEOUT_S, TrialInfo, TrialOptions
from evtribo.documents.session import (
    SESSION_FILE,
    Session,
    SessionTrial,
    read_session,
    write_session,
)
from evtribo.errors import ConfigError
from evtribo.session.check import TrialCheck, check_recorded
from evtribo.session.trialfiles import REJECTED, first_free, trial_files
from evtribo.session.trialfiles import reject as set_aside

log = logging.getLogger(__name__)

__all__ = ["REJECTED", "SessionConfig", "SessionOutcome", "run_session"]

#: Longest wait for the amplifier's status to confirm a command before a trial, s.
SETTLE_S = 2.0
#: Ways a trial ends that stop the session (the bus or the disk failed).
FAULTS = ("bus-error", "disk-error", "no-rig-data")


def _then(first: Callable[[Any], None] | None, then: Callable[[], None]
          ) -> Callable[[Any], None]:
    """A ``started`` callback that calls *first* (if any), then *then*."""
    def started(paths: Any) -> None:
        if first is not None:
            first(paths)
        then()
    return started


@dataclass
class SessionConfig:
    """How to run a session.

    Attributes
    ----------
    protocol : path
        The protocol file.
    study : path
        The study folder (created for *rig* when it has none).
    subject : str
    yes : bool
        Never ask: keep every trial, go on after each pause.
    rig : path, optional
        Rig TOML for a new study.
    settings : BusSettings, optional
        How the bus was opened (recorded in every sidecar).
    view : LiveView, optional
        The live view in the browser.
    stream : text file
        Where the display and messages go.
    ask : callable
        Asks the operator a question, returns the answer (``input``).
    display : bool
        Show the live display on *stream*.
    check : bool
        Check each trial with the analysis.
    rig_data_timeout : float or None, s
    stop_guard : callable, optional
        Returns a context manager, entered while a trial records, that gives the trial's
        stop request (a callable; the command line's turns Ctrl-C and SIGTERM into it, so
        that the trial ends as ``interrupted`` with its log saved).
    """

    protocol: str | Path
    study: str | Path
    subject: str
    yes: bool = False
    rig: str | Path | None = None
    settings: BusSettings | None = None
    view: LiveView | None = None
    stream: TextIO = field(default_factory=lambda: sys.stdout)
    #: Asks the operator a question, returns the answer (the built-in ``input``).
    ask: Callable[[str], str] = input
    display: bool = True
    check: bool = True
    rig_data_timeout: float | None = RIG_DATA_TIMEOUT_S
    stop_guard: Callable[[], AbstractContextManager[Callable[[], bool] | None]] | None = None


@dataclass
class SessionOutcome:
    """What a run of a session did.

    Attributes
    ----------
    session_file : Path
    recorded : list of str
        Trials recorded and kept in this run.
    rejected : list of str
        Recordings moved to ``rejected/`` in this run.
    planned, done : int
        Trials in the plan, and done so far (this run and earlier ones).
    stopped : str or None
        Why the run stopped before the end (``"interrupted"``, a fault, ``"stopped"`` by
        the operator), None when every trial is done.
    """

    session_file: Path
    recorded: list[str] = field(default_factory=list)
    rejected: list[str] = field(default_factory=list)
    planned: int = 0
    done: int = 0
    stopped: str | None = None


def _plan(cfg: SessionConfig, protocol: Protocol, subject_dir: Path) -> Session:
    """A new session: the plan, with the trials' names."""
    seed = session_seed(protocol)
    first = first_free(subject_dir)
    order = tuple(SessionTrial(trial=f"run-{first + i:02d}", waveform=p.waveform,
                               frequency_Hz=p.frequency_Hz, amplitude_V=p.amplitude_V,
                               condition=p.condition)
                  for i, p in enumerate(plan_trials(protocol, seed)))
    return Session(subject=cfg.subject, seed=seed, protocol=protocol.to_dict(), order=order)


def _load_or_plan(cfg: SessionConfig, protocol: Protocol, subject_dir: Path
                  ) -> tuple[Session, bool]:
    """The subject's session: read when it has one (and its protocol is the same), else
    planned and written; and whether it was read."""
    path = subject_dir / SESSION_FILE
    if path.exists():
        doc = read_session(path)
        # a session begun before a [session] setting existed has its default
        kept = {**doc.protocol, "session": {**Protocol(SessionSettings(), ()).to_dict()[
            "session"], **doc.protocol.get("session", {})}}
        if kept != protocol.to_dict():
            raise ConfigError(
                f"differs from the protocol this subject's session began with (kept in "
                f"{path}): finish that session with the same protocol, or record this one "
                "under another subject", path=cfg.protocol)
        return doc, True
    doc = _plan(cfg, protocol, subject_dir)
    subject_dir.mkdir(parents=True, exist_ok=True)
    write_session(path, doc)
    return doc, False


class _IdleReader:
    """Reads the bus between trials and drops what it reads, so that frames do not pile up
    in the adapter's and the driver's buffers and reach the next trial's log late (with the
    times they are read at, not sent at)."""

    def __init__(self, bus: can.BusABC) -> None:
        self.bus = bus
        self.dropped = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="evtribo-idle-bus",
                                        daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                if self.bus.recv(timeout=0.05) is not None:
                    self.dropped += 1
            except Exception as err:  # the next trial will meet the fault and record it
                log.debug("reading the bus between trials: %s", err)
                return

    def stop(self) -> None:
        """Stop reading, after reading away what is waiting now."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        try:
            while self.bus.recv(timeout=0) is not None:
                self.dropped += 1
        except Exception as err:
            log.debug("reading the bus between trials: %s", err)


class _Session:
    """One run of a session (see :func:`run_session`)."""

    def __init__(self, bus: can.BusABC, cfg: SessionConfig) -> None:
        self.bus, self.cfg = bus, cfg
        self.protocol = read_protocol(cfg.protocol)
        check_name(cfg.subject, "subject")
        self.rig: AcquisitionRig = open_study(cfg.study, cfg.rig)
        self.subject_dir = Path(cfg.study) / cfg.subject
        self.doc, resumed = _load_or_plan(cfg, self.protocol, self.subject_dir)
        self._saved = self.doc
        self.notes = [p.notes for p in plan_trials(self.protocol, self.doc.seed)]
        self.path = self.subject_dir / SESSION_FILE
        self.out = SessionOutcome(self.path, planned=len(self.doc.order),
                                  done=len(self.doc.done))
        self.command = (ExcitationCommand(bus, self.rig.database, self.rig.signals)
                        if ExcitationCommand.available(self.rig.signals) else None)
        self.idle = _IdleReader(bus)
        if resumed:
            self.say(f"{self.path}: {len(self.doc.done)} of {len(self.doc.order)} trials "
                     "done; going on")
        else:
            self.say(f"{self.path}: {len(self.doc.order)} trials planned (seed "
                     f"{self.doc.seed})")

    def say(self, text: str) -> None:
        self.cfg.stream.write(text + "\n")
        self.cfg.stream.flush()

    def save(self) -> None:
        if self.doc != self._saved:  # a run that records nothing writes nothing
            write_session(self.path, self.doc)
            self._saved = self.doc
        self.out.done = len(self.doc.done)

    def ask(self, question: str, default: str) -> str:
        if self.cfg.yes:
            return default
        answer = self.cfg.ask(question).strip().lower()
        return answer or default

    # -- one trial --------------------------------------------------------------------
    def excitation(self, entry: SessionTrial) -> Excitation:
        state = Excitation(entry.condition != "off", float(entry.amplitude_V or 0.0),
                           float(entry.frequency_Hz or 0.0), entry.waveform or "square")
        if self.command is None:
            what = (f"{entry.waveform} {entry.frequency_Hz:g} Hz {entry.amplitude_V:g} V, "
                    f"{entry.condition}")
            self.say(f"set the amplifier: {what}")
            self.ask("press Enter when it is set ", "")
        return state

    def record(self, entry: SessionTrial, number: int) -> Any:
        s = self.protocol.session
        title = (f"{self.cfg.subject}/{entry.trial}  ({number}/{len(self.doc.order)}: "
                 f"{entry.waveform} {entry.frequency_Hz:g} Hz {entry.amplitude_V:g} V "
                 f"{entry.condition})")
        monitor = Monitor(self.rig, self.cfg.stream, duration=s.trial_s,
                          target=s.target_force_N, band=s.band_N, title=title,
                          tare_s=s.tare_s, rig_data_timeout=self.cfg.rig_data_timeout,
                          view=self.cfg.view, quiet=not self.cfg.display,
                          steps=s.target_steps_N, step_s=s.step_s,
                          ) if (self.cfg.display or self.cfg.view) else None
        info = TrialInfo(waveform=entry.waveform, frequency_Hz=entry.frequency_Hz,
                         amplitude_V=entry.amplitude_V, condition=entry.condition,
                         notes=self.notes[number - 1] or None, tare_s=s.tare_s)
        options = TrialOptions(duration=s.trial_s, info=info, rig=self.cfg.rig,
                               settings=self.cfg.settings, monitor=monitor,
                               rig_data_timeout=self.cfg.rig_data_timeout)
        state = self.excitation(entry)
        self.idle.stop()
        try:
            return self._record(entry, state, options)
        finally:
            self.idle.start()

    def settle(self, state: Excitation) -> bool:
        """Command the amplifier off with the trial's settings, and wait (at most
        :data:`SETTLE_S`) until its status says so, so that the log does not start with the
        previous trial's excitation; False (and a warning) when it does not."""
        assert self.command is not None
        off = replace(state, enabled=False)
        status = {k: self.rig.signals.get(f"excitation_{k}") for k in ("enabled", "amplitude")}
        if status["enabled"] is None:
            self.command.send(off)
            time.sleep(0.2)
            return True
        message = self.rig.database.get_message_by_name(status["enabled"].split(".")[0])
        deadline = time.monotonic() + SETTLE_S
        next_send = 0.0
        while (now := time.monotonic()) < deadline:
            if now >= next_send:
                self.command.send(off)
                next_send = now + 0.1
            msg = self.bus.recv(timeout=0.05)
            if msg is None or msg.arbitration_id != message.frame_id \
                    or msg.is_extended_id != bool(message.is_extended_frame):
                continue
            try:
                values = message.decode(bytes(msg.data), decode_choices=False)
            except Exception:
                continue
            if not isinstance(values, dict):
                continue
            on = values.get(status["enabled"].split(".")[1])
            amp = values.get(status["amplitude"].split(".")[1]) if status["amplitude"] else None
            if on == 0 and (not isinstance(amp, int | float)
                            or abs(amp - state.amplitude_V) <= max(1.0, 0.01 * state.amplitude_V)):
                return True
        log.warning("the amplifier's status does not confirm the command (off, %g V) after %g s",
                    state.amplitude_V, SETTLE_S)
        return False

    def _record(self, entry: SessionTrial, state: Excitation, options: TrialOptions) -> Any:
        """Record with the stop guard, the amplifier commanded meanwhile when it can be."""
        s = self.protocol.session
        if self.command is not None:
            self.settle(state)
        guard = self.cfg.stop_guard() if self.cfg.stop_guard else nullcontext(None)
        with guard as should_stop:
            options = replace(options, should_stop=should_stop)
            if self.command is None:
                return record_trial(self.bus, self.cfg.study, self.cfg.subject, entry.trial,
                                    options)
            # the phases begin when the log is open: a busy machine that takes seconds to
            # open it cannot make the amplifier switch on within the tare stretch
            with self.command.hold(state, entry.condition or "alternating",
                                   off_first_s=s.tare_s, on_s=s.on_s, off_s=s.off_s,
                                   begin=False) as holder:
                options = replace(options, started=_then(options.started, holder.begin))
                return record_trial(self.bus, self.cfg.study, self.cfg.subject,
                                    entry.trial, options)

    def check(self, entry: SessionTrial) -> TrialCheck | None:
        if not self.cfg.check:
            return None
        result = check_recorded(self.cfg.study, self.cfg.subject, entry.trial,
                                entry.condition)
        if result is None:  # the study cannot be read as a whole: said, the trial kept
            return None
        first, *rest = result.lines()
        self.say(f"check: {first}")
        for line in rest:  # each reason, before the operator decides
            self.say(line)
        return result

    def reject(self, entry: SessionTrial, why: str) -> None:
        name = set_aside(self.subject_dir, entry.trial)
        if name is not None:
            self.out.rejected.append(name)
            self.say(f"{entry.trial} {why}: kept as {self.subject_dir / REJECTED / name}.*")
        self.save()

    def one(self, entry: SessionTrial, number: int) -> str | None:
        """Record *entry* until kept; the reason to stop the session, or None."""
        while True:
            if trial_files(self.subject_dir, entry.trial):
                self.reject(entry, "was left unfinished by an earlier run")
            result = self.record(entry, number)
            if result.ended == "interrupted":
                self.reject(entry, "was interrupted")
                return "interrupted"
            if result.ended in FAULTS:
                self.reject(entry, f"ended in a fault ({result.ended})")
                return result.ended
            check = self.check(entry)
            default = "k" if check is None or check.ok or self.cfg.yes else "r"
            answer = self.ask(f"keep {entry.trial}? [k]eep, [r]edo, [s]top "
                              f"(default {default}): ", default)
            if answer.startswith("r"):
                self.reject(entry, "is to be redone")
                continue
            self.doc = self.doc.with_done(entry.trial)
            self.out.recorded.append(entry.trial)
            self.save()
            return "stopped" if answer.startswith("s") else None

    def pause(self) -> None:
        s = self.protocol.session
        if s.pause_s <= 0:
            return
        if self.cfg.yes:
            self.say(f"pause: {s.pause_s:g} s")
            time.sleep(s.pause_s)
        else:
            self.ask(f"pause ({s.pause_s:g} s suggested); press Enter for the next trial ", "")

    def run(self) -> SessionOutcome:
        self.idle.start()
        try:
            while (entry := self.doc.next_trial()) is not None:
                number = self.doc.order.index(entry) + 1
                stop = self.one(entry, number)
                if stop is not None:
                    self.out.stopped = stop
                    break
                if self.doc.next_trial() is not None:
                    self.pause()
        except KeyboardInterrupt:
            self.out.stopped = "interrupted"
        finally:
            self.idle.stop()
        self.save()
        left = len(self.doc.order) - len(self.doc.done)
        self.say(f"{len(self.doc.done)} of {len(self.doc.order)} trials done"
                 + (f"; {left} to go: run the same command again to go on" if left else ""))
        return self.out


def run_session(bus: can.BusABC, config: SessionConfig) -> SessionOutcome:
    """Run (or go on with) a subject's session on *bus*.

    Parameters
    ----------
    bus : can.BusABC
        An open bus (left open).
    config : SessionConfig

    Returns
    -------
    SessionOutcome

    Raises
    ------
    ConfigError
        A bad protocol file, or one that differs from the session's.
    StudyError, RigConfigError
        A bad subject name, study or rig.
    """
    return _Session(bus, config).run()
