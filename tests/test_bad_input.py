"""Every bad input of docs/errors.md, run: the exit code and the message the table gives,
no traceback, and nothing written.

The table in docs/errors.md is the specification: each row names a case (``id``), the
command (``STUDY``, ``OUT``, ``TMP`` stand for the folders the test makes), the exit code and
text the error message contains. :data:`BUILD` makes each case's input from a valid study;
a row without a builder, or a builder without a row, fails the suite.
"""

from __future__ import annotations

import gzip
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

import _forked
import _studies
from evtribo.canlog.rig import default_rig_path
from evtribo.cli import main
from evtribo.store.lock import WriteLock
from evtribo.store.owned import claim

ERRORS_MD = Path(__file__).parents[1] / "docs" / "errors.md"
DBC = default_rig_path().with_name("default.dbc")
LOG = ("(1763700000.000000) vcan0 0C1#0000000000000000\n"
       "(1763700000.001000) vcan0 0C2#0000000000000000\n")
SIDECAR = {"subject": "P01", "waveform": "square", "frequency_Hz": 10000, "amplitude_V": 140,
           "condition": "alternating"}
RIG = {"dbc": "rig/default.dbc", "normal_force": "FzCell.Fz", "tangential_force": "FxCell.Fx"}
#: A DBC of another rig: none of its messages is in the study's log.
OTHER_DBC = ('VERSION ""\nNS_ :\nBS_:\nBU_: Cell\nBO_ 768 Cell: 8 Cell\n'
             ' SG_ F : 0|16@1- (0.001,0) [-30|30] "N" Vector__XXX\n')

PEER_LOGS = Path(__file__).parent / "data" / "logs"
CANDUMP_PLAIN = ("  vcan0  0C1   [8]  00 00 00 00 00 00 00 00\n"
                 "  vcan0  0C2   [8]  00 00 00 00 00 00 00 00\n")
SAVVYCAN = ("Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8\n"
            "166064000,000000C1,false,Rx,0,8,00,00,00,00,00,00,00,00,\n")


def _csv_log(path: Path) -> None:
    """A python-can CSV log of two frames."""
    import can

    with can.Logger(path) as writer:
        for i in range(2):
            writer.on_message_received(can.Message(timestamp=1763700000 + i * 1e-3,
                                                   arbitration_id=0xC1, is_extended_id=False,
                                                   data=bytes(8)))


def make_study(root: Path) -> None:
    """A valid study: study.toml, the default rig's DBC, one trial with its sidecar."""
    _studies.make_study(root, {"P01/run-01": SIDECAR}, name="bad input", rig=RIG, log=LOG,
                        dbc=DBC)


def _toml(study: Path, old: str, new: str) -> None:
    path = study / "study.toml"
    text = path.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new), encoding="utf-8")


def _append(study: Path, text: str) -> None:
    path = study / "study.toml"
    path.write_text(path.read_text(encoding="utf-8") + "\n" + text, encoding="utf-8")


def _sidecar(study: Path, **values: object) -> None:
    (study / "P01" / "run-01.json").write_text(json.dumps({**SIDECAR, **values}),
                                               encoding="utf-8")


#: Packages made unimportable by :func:`_without_dask`, importable again after each test.
_DASK_PACKAGES = ("dask", "distributed", "asammdf")


def _without_dask() -> None:
    """The dask extra not installed: ``import distributed`` fails (undone after the test)."""
    for name in _DASK_PACKAGES:
        sys.modules[name] = None  # type: ignore[assignment]


#: Dask clusters started by :func:`_scheduler_without_workers`, closed after each test.
_CLUSTERS: list[object] = []


def _scheduler_without_workers() -> None:
    """A Dask scheduler (in this process) with no worker, named by the environment."""
    import distributed

    cluster = distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=":0")
    _CLUSTERS.append(cluster)
    os.environ["EVTRIBO_DASK_SCHEDULER"] = cluster.scheduler_address


@pytest.fixture(autouse=True)
def _dask_importable_again():
    saved = {n: sys.modules[n] for n in _DASK_PACKAGES if n in sys.modules}
    yield
    for name in _DASK_PACKAGES:
        sys.modules.pop(name, None)
    sys.modules.update(saved)
    os.environ.pop("EVTRIBO_DASK_SCHEDULER", None)
    while _CLUSTERS:
        _CLUSTERS.pop().close()  # type: ignore[attr-defined]


#: Lock files held open by :func:`_hold_out`, for the rest of the test session.
_HELD: list[int] = []


def _hold_out(tmp: Path) -> None:
    """Another writer holds the lock on OUT (a lock file beside it, flock'ed)."""
    import fcntl

    from evtribo.store.resultdir import lock_path

    path = lock_path(tmp / "out")
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    os.write(fd, json.dumps({"pid": 4321, "command": "evtribo analyze"}).encode())
    _HELD.append(fd)


def _results(tmp: Path, *, summary: bool = True, fit_of: str | None = None,
             changed: bool = False, cut: str | None = None,
             edit: dict[str, object] | None = None, n_on: str | None = None) -> None:
    """A small result folder of analysis ``aaaa``: its tables (electrostatic.csv with a
    column of ON windows *n_on* when given), summary.json (optional, with the keys *edit*
    sets), a model fit of analysis *fit_of*, a table *changed* after the analysis, a file
    *cut* to half its length."""
    import hashlib

    out = tmp / "out"
    out.mkdir()
    tables = {
        "trials.csv": "subject,trial\nP01,run-01\n",
        "windows.csv": "subject,trial,condition,amplitude_V,waveform,normal_force_N,"
                       "friction_force_N\nP01,run-01,on,140,square,0.5,0.3\n",
        "electrostatic.csv": "subject,waveform,amplitude_V,mu,normal_force_on_N,"
                             "electrostatic_force_N,electrostatic_force_ci_low_N,"
                             "electrostatic_force_ci_high_N\nP01,square,140,0.5,0.5,0.1,"
                             "0.09,0.11\n"}
    if n_on is not None:
        head, row = tables["electrostatic.csv"].splitlines()
        tables["electrostatic.csv"] = f"{head},n_on\n{row},{n_on}\n"
    for name, text in tables.items():
        (out / name).write_text(text, encoding="utf-8")
    if summary:
        (out / "summary.json").write_text(json.dumps({
            "run_id": "aaaa", "study_dir": str(tmp / "study"),
            "output_sha256": {n: hashlib.sha256(t.encode()).hexdigest()
                              for n, t in tables.items()}, **(edit or {})}),
            encoding="utf-8")
    if fit_of is not None:
        (out / "fit.csv").write_text("subject,parameter,value\nP01,h_L,5e-06\n")
        (out / "fit.json").write_text(json.dumps({"run_id": fit_of, "figures": []}))
    if fit_of == "aaaa":  # fit.json records what compare wrote
        doc = json.loads((out / "fit.json").read_text())
        doc["output_sha256"] = {"fit.csv": hashlib.sha256(
            (out / "fit.csv").read_bytes()).hexdigest()}
        (out / "fit.json").write_text(json.dumps(doc))
    if changed:
        (out / "electrostatic.csv").write_text(tables["electrostatic.csv"].replace(
            "0.1,", "0.2,"), encoding="utf-8")
    if cut is not None:
        data = (out / cut).read_bytes()
        (out / cut).write_bytes(data[: len(data) // 2])


def _session_begun(tmp: Path) -> None:
    """P01's session begun with amplitudes 60 and 100 V; the protocol now asks 140 V."""
    from evtribo.documents.session import Session, SessionTrial, write_session

    old = {"session": {"trial_s": 20.0}, "trial": [{"amplitude_V": [60.0, 100.0]}]}
    write_session(tmp / "study" / "P01" / "session.json", Session(
        subject="P01", seed=1, protocol=old,
        order=(SessionTrial("run-09", "square", 10000.0, 60.0, "alternating"),)))
    (tmp / "protocol.toml").write_text("[[trial]]\namplitude_V = 140\n")


SIDECAR_TWICE = ('{\n  "subject": "P01", "waveform": "square", "frequency_Hz": 10000,\n'
                 '  "amplitude_V": 140, "condition": "alternating",\n  "amplitude_V": 14\n}\n')
PASSWD = "root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n"
ASC = ("date Mon Nov 23 06:19:31.000 am 2026\nbase hex  timestamps absolute\n"
       "internal events logged\nBegin Triggerblock Mon Nov 23 06:19:31.000 am 2026\n"
       "   0.000000 1  0C1             Rx   d 8 00 00 00 00 00 00 00 00\n"
       "End TriggerBlock\n")


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new), encoding="utf-8")


def _fifo(path: Path) -> None:
    """*path* replaced by a FIFO (named pipe)."""
    path.unlink()
    os.mkfifo(path)


def _sliding_trial(tmp: Path) -> None:
    """A simulated trial of the finger sliding, run-02 of the study."""
    from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial

    write_trial(tmp / "study", "run-02", SubjectParams(), TrialConfig(duration_s=4.0, seed=3))


def _link(link: Path, target: Path) -> None:
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(target)


def _text(path: Path, text: str) -> Callable[[Path], None]:
    def build(tmp: Path) -> None:
        (tmp / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp / path).write_text(text, encoding="utf-8")
    return build


def _planted_record(tmp: Path) -> None:
    """A result folder, and beside it a commit record whose target is a trial's folder."""
    import hashlib

    _results(tmp)
    stage = tmp / f".out.evtribo-new-{'0' * 32}"
    stage.mkdir()
    evil = b"(1763700000.000000) vcan0 7FF#DEADBEEF\n"
    (stage / "run-01.log").write_bytes(evil)
    digest = hashlib.sha256(evil).hexdigest()
    (stage / ".evtribo-commit.json").write_text(json.dumps({
        "evtribo": "commit", "version": 2, "unit": "out", "target": "study/P01",
        "by": "analyze", "install": [["run-01.log", digest, None]], "remove": []}))


def _compare_figure(tmp: Path) -> None:
    """A result folder with a figure compare wrote in its figures/ (its manifest lists it)."""
    import hashlib

    from evtribo.store.manifest import Entry, record

    _results(tmp, fit_of="aaaa")
    figure = tmp / "out" / "figures" / "area_increase.png"
    figure.parent.mkdir()
    figure.write_bytes(b"a figure\n")
    record(tmp / "out", {"figures/area_increase.png": Entry(
        hashlib.sha256(b"a figure\n").hexdigest(), "compare")})


def _unreadable(*paths: str) -> Callable[[Path], None]:
    """Each of *paths* (under TMP) of mode 000: a user may not read it (nor list or enter a
    folder). The case runs in a process that obeys the modes (:data:`AS_A_USER`)."""
    def build(tmp: Path) -> None:
        for path in paths:
            (tmp / path).chmod(0)
    return build


#: The cases run in a forked process held to the files' modes (:func:`_forked.modes_apply`).
AS_A_USER = {"log-unreadable", "sidecar-unreadable", "study-toml-unreadable",
             "dbc-unreadable", "subject-folder-unreadable", "inspect-log-unreadable",
             "decode-dbc-unreadable", "export-log-unreadable", "plot-log-unreadable",
             "calibrate-log-unreadable", "session-protocol-unreadable",
             "acquire-rig-unreadable", "compare-params-unreadable",
             "compare-summary-unreadable"}


#: Locks the builders hold while their case runs (released after it).
HELD: list[WriteLock] = []


def _being_recorded(tmp: Path) -> None:
    """P01/run-01 is being recorded: its lock is held (here, by this process)."""
    HELD.append(WriteLock(tmp / "study" / "P01" / "run-01.lock", "the trial P01/run-01",
                          "recorded").acquire())


@pytest.fixture(autouse=True)
def _release_held_locks():
    yield
    while HELD:
        HELD.pop().release()


#: case id -> how to make its input (in TMP, which holds a valid study in TMP/study).
BUILD: dict[str, Callable[[Path], None]] = {
    "toml-syntax": lambda t: _toml(t / "study", 'name = "bad input"', 'name = "bad input'),
    "toml-unknown-key": lambda t: _toml(t / "study", "name =", "subject = 'P01'\nname ="),
    "toml-wrong-type": lambda t: _toml(t / "study", 'name = "bad input"', "name = 3"),
    "toml-no-rig": lambda t: (t / "study" / "study.toml").write_text('name = "x"\n'),
    "rig-unknown-key": lambda t: _toml(t / "study", "normal_force =", "normal_forse ="),
    "rig-missing-key": lambda t: _toml(t / "study", 'tangential_force = "FxCell.Fx"\n', ""),
    "rig-not-a-string": lambda t: _toml(t / "study", '"FzCell.Fz"', "3"),
    "rig-counter-period-too-large": lambda t: _toml(
        t / "study", 'normal_force = "FzCell.Fz"\n',
        'normal_force = "FzCell.Fz"\nnormal_force_counter_period = 300\n'),
    "rig-counter-period-text": lambda t: _toml(
        t / "study", 'normal_force = "FzCell.Fz"\n',
        'normal_force = "FzCell.Fz"\ntangential_force_counter_period = "100"\n'),
    "dbc-missing": lambda t: _toml(t / "study", "rig/default.dbc", "rig/loadcells.dbc"),
    "dbc-not-parsing": lambda t: (t / "study" / "rig" / "default.dbc").write_text(
        'VERSION ""\n\nBO_ 193 FzCell: 8 Vector__XXX\n SG_ Fz : 0|16@1+ (0.001,0) [0|65] "N"\n'
        " Vector__XXX\nBO_ this line is not DBC\n"),
    "signal-missing": lambda t: _toml(t / "study", '"FzCell.Fz"', '"FzCell.Force"'),
    "message-missing": lambda t: _toml(t / "study", '"FzCell.Fz"', '"NormalCell.Fz"'),
    "signal-malformed": lambda t: _toml(t / "study", '"FzCell.Fz"', '"Fz"'),
    "rig-same-signal": lambda t: _toml(t / "study", 'tangential_force = "FxCell.Fx"',
                                       'tangential_force = "FzCell.Fz"'),
    "sidecar-json": lambda t: (t / "study" / "P01" / "run-01.json").write_text(
        '{"subject": "P01",\n "amplitude_V": 140,\n}\n'),
    "sidecar-subject-path": lambda t: _sidecar(t / "study", subject="../P02"),
    "sidecar-waveform": lambda t: _sidecar(t / "study", waveform="triangle"),
    "sidecar-amplitude-string": lambda t: _sidecar(t / "study", amplitude_V="140 V"),
    "sidecar-negative": lambda t: _sidecar(t / "study", frequency_Hz=-10000),
    "sidecar-amplitude-400-digits": lambda t: _sidecar(t / "study", amplitude_V=10**400),
    "sidecar-condition": lambda t: _sidecar(t / "study", condition="half"),
    "subject-folder-name": lambda t: (t / "study" / "P01").rename(t / "study" / "P 01"),
    "two-logs-one-trial": lambda t: (t / "study" / "P01" / "run-01.asc").write_text(""),
    "sidecar-subject-folder": lambda t: _sidecar(t / "study", subject="P02"),
    "sidecar-fifo": lambda t: (t / "study" / "P01" / "run-01.json").unlink()
    or os.mkfifo(t / "study" / "P01" / "run-01.json"),
    "sidecar-device": lambda t: (t / "study" / "P01" / "run-01.json").unlink()
    or (t / "study" / "P01" / "run-01.json").symlink_to("/dev/zero"),
    "sidecar-nested-deep": lambda t: (t / "study" / "P01" / "run-01.json").write_text(
        "[" * 100_000 + "]" * 100_000),
    "not-a-study": lambda t: (t / "study" / "study.toml").unlink(),
    "unknown-command": lambda t: None,
    "no-such-study": lambda t: None,
    "no-trials": lambda t: shutil.rmtree(t / "study" / "P01"),
    "results-exist": lambda t: (_text(Path("out/trials.csv"), "subject,trial\n")(t),
                                claim(t / "out" / "trials.csv", "analyze")),
    "analysis-unknown-key": lambda t: _append(t / "study", "[analysis]\nguard_sec = 0.3\n"),
    "analysis-tare-mode": lambda t: _append(t / "study", '[analysis]\ntare = "zero"\n'),
    "analysis-negative": lambda t: _append(t / "study", "[analysis]\nguard_s = -0.1\n"),
    "analysis-friction-law": lambda t: _append(t / "study",
                                               '[analysis]\nfriction_law = "coulomb"\n'),
    "analysis-not-a-number": lambda t: _append(t / "study", '[analysis]\nn_boot = "many"\n'),
    "analysis-n-boot-inf": lambda t: _append(t / "study", "[analysis]\nn_boot = inf\n"),
    "analysis-n-boot-huge": lambda t: _append(t / "study", "[analysis]\nn_boot = 1e9\n"),
    "analyze-set-unknown": lambda t: None,
    "analyze-set-syntax": lambda t: None,
    "calibration-unknown-key": lambda t: _append(
        t / "study", "[rig.calibration]\nnormal_offset = 0.01\n"),
    "calibration-not-a-number": lambda t: _append(
        t / "study", '[rig.calibration]\ntangential_offset_N = "0.01 N"\n'),
    "calibration-matrix-shape": lambda t: _append(
        t / "study", "[rig.calibration]\nmatrix = [[1.0, 0.0]]\n"),
    "calibration-matrix-singular": lambda t: _append(
        t / "study", "[rig.calibration]\nmatrix = [[1.0, 2.0], [2.0, 4.0]]\n"),
    "acquire-tare-negative": lambda t: None,
    "acquire-name-too-long": lambda t: None,
    "strict-damaged-line": lambda t: (t / "study" / "P01" / "run-01.log").write_text(
        LOG + "(1763700000.002000) vcan0 0C1#000000000000000\n"),
    "strict-impossible-timestamp": lambda t: (t / "study" / "P01" / "run-01.log").write_text(
        LOG + "(9223372036854775808.000000) vcan0 0C1#0000000000000000\n"),
    "jobs-zero": lambda t: None,
    "analyze-dask-missing": lambda t: _without_dask(),
    "compare-dask-missing": lambda t: _results(t) or _without_dask(),
    "analyze-dask-unreachable": lambda t: None,
    "analyze-dask-no-workers": lambda t: _scheduler_without_workers(),
    "log-unknown-suffix": _text(Path("run-01.txt"), LOG),
    "log-suffix-typo": _text(Path("run-01.lgo"), LOG),
    "log-missing": lambda t: None,
    "decode-output-suffix": lambda t: None,
    "decode-output-exists": lambda t: (_text(Path("run-01.csv"), "timestamp\n")(t),
                                       claim(t / "run-01.csv", "decode")),
    "decode-dbc-missing": lambda t: None,
    "decode-mf4-choices": lambda t: None,
    "decode-mf4-no-message": _text(Path("other.dbc"), OTHER_DBC),
    "decode-mf4-asammdf-missing": lambda t: sys.modules.update({"asammdf": None}),
    "export-output-suffix": lambda t: None,
    "export-subject-unknown": lambda t: None,
    "export-output-exists": lambda t: (_text(Path("forces.mf4"), "an earlier export\n")(t),
                                       claim(t / "forces.mf4", "export")),
    "model-set-unknown": lambda t: None,
    "model-set-not-a-number": lambda t: None,
    "model-set-syntax": lambda t: None,
    "model-set-negative": lambda t: None,
    "model-normal-force-huge": lambda t: None,
    "model-set-huge": lambda t: None,
    "compare-no-results": lambda t: None,
    "compare-fit-unknown": _text(Path("out/electrostatic.csv"), "subject\n"),
    "compare-fit-friction-law": _text(Path("out/electrostatic.csv"), "subject\n"),
    "compare-models-unknown": _text(Path("out/electrostatic.csv"), "subject\n"),
    "compare-params-not-toml": _text(Path("params.toml"), "h_L = = 3\n"),
    "compare-figure-format-unknown": _results,
    "compare-figure-width-unknown": _results,
    "compare-dpi-zero": _results,
    "report-no-results": lambda t: None,
    "report-tables-unknown-format": lambda t: None,
    "acquire-subject-path": lambda t: None,
    "acquire-amplitude-string": lambda t: None,
    "acquire-waveform": lambda t: None,
    "acquire-rig-not-toml": _text(Path("rig.toml"), "dbc = default.dbc\n"),
    "acquire-trial-exists": lambda t: None,
    "acquire-bus-option": lambda t: None,
    "acquire-receive-buffer": lambda t: None,
    "acquire-receive-buffer-huge": lambda t: None,
    "acquire-duration-inf": lambda t: None,
    "acquire-amplitude-inf": lambda t: None,
    "acquire-band-nan": lambda t: None,
    "acquire-target-force-nan": lambda t: None,
    "acquire-study-is-a-file": _text(Path("notes.txt"), "not a study\n"),
    "acquire-rig-is-a-folder": lambda t: (t / "rigs").mkdir(),
    "acquire-rig-not-utf8": lambda t: (t / "rig.toml").write_bytes(b'name = "caf\xe9"\n'),
    "acquire-trial-exists-bad-interface": lambda t: None,
    "acquire-new-study-bad-interface": lambda t: None,
    "acquire-trial-locked": _being_recorded,
    "simulate-trial-locked": _being_recorded,
    "simulate-over-recording": lambda t: _sidecar(t / "study", bus={"interface": "socketcan",
                                                                    "channel": "can0"}),
    "simulate-subjects-no-study": lambda t: None,
    "simulate-subjects-zero": lambda t: None,
    "simulate-subjects-one-trial-option": lambda t: None,
    "simulate-spread-negative": lambda t: None,
    "simulate-amplitudes-text": lambda t: None,
    "analyze-out-inside-study": lambda t: None,
    "analyze-out-busy": _hold_out,
    "compare-results-mixed": lambda t: _results(t, changed=True),
    "compare-results-partial": lambda t: _results(t, summary=False),
    "compare-count-not-whole": lambda t: _results(t, n_on="2.5"),
    "report-fit-of-another-analysis": lambda t: _results(t, fit_of="bbbb"),
    "report-fit-half-written": lambda t: _results(t, fit_of="aaaa", cut="fit.csv"),
    "compare-summary-half-written": lambda t: _results(t, cut="summary.json"),
    "analyze-out-is-a-file": _text(Path("out"), "not a folder\n"),
    "log-candump-no-timestamps": _text(Path("run-01.log"), CANDUMP_PLAIN),
    "log-asc-named-log": lambda t: shutil.copy(PEER_LOGS / "logfile.asc", t / "run-01.log"),
    "log-savvycan-csv": _text(Path("run-01.csv"), SAVVYCAN),
    "log-utf16": lambda t: (t / "a80.log").write_text(
        "(1763700000.000000) vcan0 0C1#0000000000000001\n" * 20, encoding="utf-16"),
    "log-no-frame": _text(Path("run-01.log"), "trial 1, P01: finger slipped at 3 s\n"),
    "log-db-gz": lambda t: (t / "run-01.db.gz").write_bytes(gzip.compress(b"SQLite format 3")),
    "log-db-unreadable": _text(Path("run-01.db"), "not a database\n"),
    "decode-output-is-input": lambda t: _csv_log(t / "run-01.csv"),
    "decode-output-is-a-log": lambda t: _csv_log(t / "run-02.csv"),
    "decode-csv-in-study": lambda t: None,
    "dbc-not-a-dbc": lambda t: (_text(Path("passwd"), PASSWD)(t),
                                _toml(t / "study", '"rig/default.dbc"', '"../passwd"')),
    "rig-signal-beyond-message": lambda t: _edit(t / "study" / "rig" / "default.dbc",
                                                 "BO_ 193 FzCell: 8", "BO_ 193 FzCell: 6"),
    "dbc-device": lambda t: _toml(t / "study", '"rig/default.dbc"', '"/dev/zero"'),
    "study-toml-fifo": lambda t: _fifo(t / "study" / "study.toml"),
    "dbc-fifo": lambda t: _fifo(t / "study" / "rig" / "default.dbc"),
    "decode-dbc-not-a-dbc": _text(Path("passwd"), PASSWD),
    "sidecar-duplicate-key": _text(Path("study/P01/run-01.json"), SIDECAR_TWICE),
    "toml-duplicate-key": lambda t: _toml(t / "study", 'name = "bad input"',
                                          'name = "bad input"\nname = "other"'),
    "analyze-cache-inside-study": lambda t: None,
    "acquire-view-port": lambda t: None,
    "report-over-log": lambda t: (t / "out").mkdir(),
    "report-over-sidecar": lambda t: (t / "out").mkdir(),
    "report-over-study-toml": lambda t: (t / "out").mkdir(),
    "report-over-dbc": lambda t: (t / "out").mkdir(),
    "report-over-other-log": lambda t: (_text(Path("bench.asc"), ASC)(t), (t / "out").mkdir()),
    "report-over-power-cut-log": lambda t: ((t / "bench.log").write_bytes(
        b"\x00" * 300_000 + LOG.encode()), (t / "out").mkdir()),
    "report-new-sidecar": lambda t: (t / "out").mkdir(),
    "report-new-sidecar-linked-subject": lambda t: (
        shutil.copytree(t / "study" / "P01", t / "elsewhere"),
        _link(t / "study" / "P02", t / "elsewhere"), (t / "out").mkdir()),
    "decode-csv-in-trials-folder-by-its-path": lambda t: (
        shutil.copytree(t / "study" / "P01", t / "elsewhere"),
        _link(t / "study" / "P02", t / "elsewhere")),
    "report-tables-over-log": lambda t: (_link(t / "tables" / "fit.md",
                                               t / "study" / "P01" / "run-01.log"),
                                         (t / "out").mkdir()),
    "compare-out-in-study": lambda t: (t / "study" / "P02").mkdir(),
    "analyze-results-not-evtribo-s": _text(Path("out/trials.csv"), "subject,trial\n"),
    "report-tables-over-users-table": lambda t: (_text(Path("tables/fit.md"), "| mine |\n")(t),
                                                 (t / "out").mkdir()),
    "report-over-result-table": lambda t: (_results(t, fit_of="aaaa"),
                                           claim(t / "out" / "trials.csv", "analyze")),
    "decode-output-not-evtribo-s": _text(Path("run-01.csv"), "timestamp\n"),
    "decode-output-name-tab": lambda t: None,
    "decode-manifest-is-a-folder": lambda t: (t / "d" / ".evtribo-manifest.json").mkdir(
        parents=True),
    "decode-output-name-evtribo-s": lambda t: None,
    "analyze-out-name-evtribo-s": lambda t: None,
    "report-output-name-too-long": lambda t: (t / "out").mkdir(),
    "compare-planted-record": _planted_record,
    "compare-figures-a-link": lambda t: (_results(t), (t / "paper").mkdir(),
                                         _link(t / "out" / "figures", t / "paper")),
    "compare-lock-not-a-lock": lambda t: (_results(t), _link(
        t / ".out.evtribo-lock", t / "study" / "P01" / "run-01.log")),
    "plot-over-log": lambda t: _link(t / "check.png", t / "study" / "P01" / "run-01.log"),
    "model-figures-over-dbc": lambda t: _link(t / "figures" / "fig5_friction_time.png",
                                              t / "study" / "rig" / "default.dbc"),
    "decode-channel-missing": lambda t: None,
    "plot-no-such-study": lambda t: None,
    "plot-subject-missing": lambda t: None,
    "plot-trial-missing": lambda t: None,
    "plot-figure-suffix": lambda t: None,
    "plot-into-compare-figures": _compare_figure,
    "plot-figure-exists": lambda t: (_text(Path("check.png"), "a figure kept\n")(t),
                                     claim(t / "check.png", "plot")),
    "plot-signal-unknown": lambda t: None,
    "plot-dbc-missing": lambda t: None,
    "plot-no-dbc": lambda t: None,
    "plot-log-missing": lambda t: None,
    "compare-summary-edited": lambda t: _results(t, edit={"study": {"name": "x"}}),
    "plan-too-few-subjects": lambda t: None,
    "plan-force-beyond-the-model": lambda t: None,
    "compare-population-exclude-unknown": lambda t: _results(t) or _append(
        t / "study", '[population]\nexclude = [{subject = "P09", reason = "recalibrated"}]'),
    "compare-population-exclude-no-reason": lambda t: _results(t) or _append(
        t / "study", '[population]\nexclude = [{subject = "P01"}]'),
    "compare-population-model-unknown": lambda t: _results(t) or _append(
        t / "study", '[population]\nmodel = "bayes"\n'),
    "session-protocol-misspelt-key": _text(Path("protocol.toml"), "[session]\ntrial_s = 20\n"
                                           "repetiton = 2\n[[trial]]\namplitude_V = 100\n"),
    "session-protocol-steps-not-a-list": _text(Path("protocol.toml"), "[session]\n"
                                               "target_steps_N = 0.3\n[[trial]]\n"),
    "session-protocol-changed": _session_begun,
    "init-study-exists": lambda t: None,
    "init-force-over-users-study-toml": lambda t: None,
    "calibrate-press-slides": _sliding_trial,
    "analyze-subject-folder": lambda t: None,
    "report-given-study": lambda t: None,
    "acquire-no-interface": lambda t: None,
    "acquire-study-misspelt": lambda t: None,
    "simulate-study-misspelt": lambda t: None,
    "init-dbc-missing": lambda t: None,
    "init-log-of-another-rig": _text(Path("other.dbc"), OTHER_DBC),
    "calibration-matrix-huge": lambda t: _append(
        t / "study", "[rig.calibration]\nmatrix = [[1e300, 0.0], [0.0, 1.0]]\n"),
    "calibration-offset-huge": lambda t: _append(
        t / "study", "[rig.calibration]\nnormal_offset_N = 1e6\n"),
    "analysis-guard-huge": lambda t: _append(t / "study", "[analysis]\nguard_s = 1e6\n"),
    "analysis-confidence-low": lambda t: _append(t / "study",
                                                 "[analysis]\nconfidence = 1e-300\n"),
    "sidecar-amplitude-huge": lambda t: _sidecar(t / "study", amplitude_V=1e6),
    "sidecar-tare-huge": lambda t: _sidecar(t / "study", tare_s=1e6),
    "acquire-amplitude-huge": lambda t: None,
    "simulate-rate-huge": lambda t: None,
    "simulate-seed-negative": lambda t: None,
    "simulate-offline-too-long": lambda t: None,
    "session-protocol-amplitude-huge": _text(Path("protocol.toml"),
                                             "[[trial]]\namplitude_V = [100, 1e6]\n"),
    "session-protocol-repetitions-huge": _text(
        Path("protocol.toml"), "[session]\nrepetitions = 1000000000\n[[trial]]\n"
        "amplitude_V = 100\n"),
    "demo-speed-zero": lambda t: None,
    "log-unreadable": _unreadable("study/P01/run-01.log"),
    "sidecar-unreadable": _unreadable("study/P01/run-01.json"),
    "study-toml-unreadable": _unreadable("study/study.toml"),
    "dbc-unreadable": _unreadable("study/rig/default.dbc"),
    "subject-folder-unreadable": _unreadable("study/P01"),
    "inspect-log-unreadable": _unreadable("study/P01/run-01.log"),
    "decode-dbc-unreadable": _unreadable("study/rig"),
    "export-log-unreadable": _unreadable("study/P01/run-01.log"),
    "plot-log-unreadable": _unreadable("study/P01/run-01.log"),
    "calibrate-log-unreadable": lambda t: (_sliding_trial(t),
                                           _unreadable("study/P01/run-02.log")(t)),
    "session-protocol-unreadable": lambda t: (
        _text(Path("protocol.toml"), "[[trial]]\namplitude_V = 100\n")(t),
        _unreadable("protocol.toml")(t)),
    "acquire-rig-unreadable": lambda t: (shutil.copy(default_rig_path(), t / "rig.toml"),
                                         _unreadable("rig.toml")(t)),
    "compare-params-unreadable": lambda t: (_results(t), _text(Path("params.toml"),
                                                               "h_L = 5e-6\n")(t),
                                            _unreadable("params.toml")(t)),
    "compare-summary-unreadable": lambda t: (_results(t), _unreadable("out/summary.json")(t)),
}


def parse_table(path: Path = ERRORS_MD) -> list[dict[str, str]]:
    """The rows of the first Markdown table in *path* whose header starts ``| id |``."""
    rows, header = [], None
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("|"):
            if header is not None and rows:
                break
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if header is None:
            if cells and cells[0] == "id":
                header = cells
            continue
        if set(line) <= set("|-: "):
            continue
        rows.append(dict(zip(header, cells, strict=True)))
    return rows


def _code(cell: str) -> str:
    m = re.fullmatch(r"(`+) ?(.*?) ?\1", cell)
    assert m, f"expected `code` in {cell!r}"
    return m.group(2)


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    return {os.fspath(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in root.rglob("*")}


def places(tmp: Path) -> dict[str, str]:
    """What the table's placeholders stand for."""
    return {"STUDY": os.fspath(tmp / "study"), "OUT": os.fspath(tmp / "out"),
            "TMP": os.fspath(tmp)}


def substitute(text: str, tmp: Path) -> str:
    """*text* with STUDY, OUT and TMP replaced by the folders under *tmp*, ``r*300`` by 300
    r's (a name too long to show) and ``<TAB>`` by a tab."""
    where = places(tmp)
    text = text.replace("r*300", "r" * 300).replace("<TAB>", "\t")
    return re.sub(r"\b(STUDY|OUT|TMP)\b", lambda m: where[m.group(1)], text)


def run_case(case: dict[str, str], tmp: Path, capsys: pytest.CaptureFixture[str]
             ) -> tuple[int, str, dict[str, tuple[int, int]]]:
    """Build the case's input under *tmp* and run its command.

    Returns the exit code, stderr, and the files under *tmp* before the command ran.
    """
    make_study(tmp / "study")
    BUILD[case["id"]](tmp)
    capsys.readouterr()
    argv = [substitute(a, tmp) for a in shlex.split(_code(case["command"]))]
    assert argv[0] == "evtribo"
    before = _tree(tmp)
    if case["id"] in AS_A_USER:
        code, err = _forked.run(argv[1:], tmp.parent / f"{tmp.name}.err", _forked.modes_apply)
        return code, err, before
    try:
        code = main(argv[1:])
    except SystemExit as exc:  # argparse's own usage errors
        code = int(exc.code or 0)
    return code, capsys.readouterr().err, before


CASES = parse_table()


def test_the_table_and_the_builders_name_the_same_cases():
    ids = [c["id"] for c in CASES]
    assert len(ids) == len(set(ids)), "a case id appears twice in docs/errors.md"
    assert set(ids) == set(BUILD)


@pytest.mark.parametrize("case", CASES, ids=[c["id"] for c in CASES])
def test_bad_input(case, tmp_path, capsys):
    code, err, before = run_case(case, tmp_path, capsys)
    assert code == int(case["exit"]), err
    expected = substitute(_code(case["message"]), tmp_path)
    assert expected in err, f"\nexpected: {expected}\n     got: {err}"
    assert "Traceback" not in err
    assert "root:x:0" not in err  # no line of a file that is not a DBC is shown
    assert _tree(tmp_path) == before, "the command wrote or changed files"


@pytest.mark.parametrize("case_id", ["sidecar-subject-path", "dbc-not-parsing",
                                     "acquire-amplitude-string"])
def test_bad_input_as_a_process(case_id, tmp_path):
    """The same through ``python -m evtribo``: the process's exit code, no traceback."""
    case = next(c for c in CASES if c["id"] == case_id)
    make_study(tmp_path / "study")
    BUILD[case_id](tmp_path)
    argv = [substitute(a, tmp_path) for a in shlex.split(_code(case["command"]))]
    before = _tree(tmp_path)
    proc = subprocess.run([sys.executable, "-m", "evtribo", *argv[1:]], capture_output=True,
                          text=True, timeout=60, check=False)
    assert proc.returncode == int(case["exit"])
    assert substitute(_code(case["message"]), tmp_path) in proc.stderr
    assert "Traceback" not in proc.stderr
    assert _tree(tmp_path) == before
