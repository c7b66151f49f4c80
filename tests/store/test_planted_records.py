"""A commit record or a lock file planted beside a result folder (a group-writable results
share, an archive that carries the hidden names) writes and deletes nothing: the record is
replayed only inside its own folder, for names evtribo writes, without following links,
and only over files evtribo wrote; one that fails a check is refused by name (exit 2)."""

from __future__ import annotations

import hashlib
import json
import os
import uuid
from pathlib import Path

import pytest

import _studies
from evtribo.canlog.rig import default_rig_path
from evtribo.cli import main
from evtribo.errors import OutputExistsError, ResultFolderError
from evtribo.store.commit_record import COMMIT_RECORD
from evtribo.store.resultdir import Staging, lock_path, locked, recover

DBC = default_rig_path().with_name("default.dbc")
LOG = b"(1763700000.000000) vcan0 0C1#0000000000000000\n"
SIDECAR = b'{"subject": "P01"}\n'
EVIL = b"(1763700000.000000) vcan0 7FF#DEADBEEF\n"


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@pytest.fixture
def share(tmp_path):
    """A results share: a result folder evtribo wrote, a study beside it, a user's file in
    the result folder and one outside every folder."""
    study = _studies.make_study(
        tmp_path / "study", {"P01/a80": None}, log=LOG.decode(), dbc=DBC,
        rig={"dbc": "rig/default.dbc", "normal_force": "FzCell.Fz",
             "tangential_force": "FxCell.Fx"})
    (study / "P01" / "a80.json").write_bytes(SIDECAR)
    out = tmp_path / "out"
    with locked(out, "evtribo analyze"), Staging(out, by="analyze") as stage:
        stage.path("trials.csv").write_text("subject,trial\n")
        stage.commit()
    (out / "notes.csv").write_text("my notes\n")
    (tmp_path / "bashrc").write_text("alias ls='ls -F'\n")
    return tmp_path


def _files(root: Path) -> dict[str, bytes]:
    return {rel: p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and not (rel := p.relative_to(root).as_posix()).startswith(".")
            and "/." not in rel}


def _plant(out: Path, doc: dict, files: dict[str, bytes]) -> Path:
    stage = out.parent / f".{out.name}.evtribo-new-{uuid.uuid4().hex}"
    stage.mkdir()
    for rel, data in files.items():  # a name climbing out is planted inside
        (stage / rel.replace("../", "")).parent.mkdir(parents=True, exist_ok=True)
        (stage / rel.replace("../", "")).write_bytes(data)
    (stage / COMMIT_RECORD).write_text(json.dumps(doc))
    return stage


def _v2(target: str, install: list, remove: list, unit: str = "out") -> dict:
    return {"evtribo": "commit", "version": 2, "unit": unit, "target": target,
            "by": "analyze", "install": install, "remove": remove}


RECORDS = {
    # as an older evtribo wrote them: a target and lists of names
    "into-the-study": lambda t: ({"target": "study/P01", "install": ["a80.log"],
                                  "remove": ["a80.json"]}, {"a80.log": EVIL}),
    "absolute-target": lambda t: ({"target": str(t), "install": ["bashrc"],
                                   "remove": ["bashrc"]}, {"bashrc": EVIL}),
    "climbing-names": lambda t: ({"target": "out", "install": ["../study/P01/a80.log"],
                                  "remove": ["../study/P01/a80.json"]},
                                 {"../study/P01/a80.log": EVIL}),
    # in this version's shape
    "v2-into-the-study": lambda t: (_v2("study/P01", [["a80.log", _sha(EVIL), _sha(LOG)]],
                                        [["a80.json", _sha(SIDECAR)]]), {"a80.log": EVIL}),
    "v2-parent-target": lambda t: (_v2(".", [["bashrc", _sha(EVIL), None]], []),
                                   {"bashrc": EVIL}),
    "v2-another-unit": lambda t: (_v2("study", [["x.csv", _sha(EVIL), None]], [],
                                      unit="study"), {"x.csv": EVIL}),
    "v2-hidden-name": lambda t: (_v2("out", [[".bashrc", _sha(EVIL), None]], []),
                                 {".bashrc": EVIL}),
}


@pytest.mark.parametrize("case", sorted(RECORDS))
def test_a_planted_record_is_refused_by_name_and_nothing_is_done(share, case):
    out = share / "out"
    before = _files(share)
    doc, files = RECORDS[case](share)
    stage = _plant(out, doc, files)
    with pytest.raises(ResultFolderError) as info, locked(out, "evtribo compare"):
        recover(out)
    assert str(stage / COMMIT_RECORD) in str(info.value) and info.value.exit_code == 2
    assert "not replayed" in str(info.value)
    assert _files(share) == before


def test_a_record_through_a_link_is_refused(share):
    out = share / "out"
    (out / "link").symlink_to(share / "study" / "P01")
    before = _files(share)
    stage = _plant(out, _v2("out/link", [["a80.log", _sha(EVIL), _sha(LOG)]], []),
                   {"a80.log": EVIL})
    with pytest.raises(ResultFolderError), locked(out, "evtribo compare"):
        recover(out)
    # a record that names a link inside its folder: the link is not followed either
    os.unlink(stage / COMMIT_RECORD)
    _plant(out, _v2("out", [["link/a80.log", _sha(EVIL), _sha(LOG)]],
                    [["link/a80.json", _sha(SIDECAR)]]), {"link/a80.log": EVIL})
    with pytest.raises(ResultFolderError), locked(out, "evtribo compare"):
        recover(out)
    assert _files(share) == before


def test_a_record_that_passes_replaces_only_files_evtribo_wrote(share):
    out = share / "out"
    notes = (out / "notes.csv").read_bytes()
    _plant(out, _v2("out", [["notes.csv", _sha(EVIL), _sha(notes)],
                            ["new.csv", _sha(EVIL), None]],
                    [["notes.csv", _sha(notes)]]), {"notes.csv": EVIL, "new.csv": EVIL})
    with locked(out, "evtribo compare"):
        recover(out)
    assert (out / "notes.csv").read_bytes() == notes  # a user's file: not replaced
    assert (out / "new.csv").read_bytes() == EVIL  # a new name inside the folder: written


@pytest.mark.parametrize("command", ["compare", "report", "analyze"])
def test_the_commands_refuse_a_planted_record_naming_it(share, command, capsys):
    out = share / "out"
    before = _files(share)
    doc, files = RECORDS["into-the-study"](share)
    stage = _plant(out, doc, files)
    argv = {"compare": ["compare", str(out), "--force"],
            "report": ["report", str(out), "--force"],
            "analyze": ["analyze", str(share / "study"), "--out", str(out), "--force"]}[command]
    assert main(argv) == 2
    assert str(stage / COMMIT_RECORD) in capsys.readouterr().err
    assert _files(share) == before


def test_a_lock_file_planted_as_a_link_to_a_log_is_never_written(share, capsys):
    out = share / "out"
    log = share / "study" / "P01" / "a80.log"
    lock_path(out).symlink_to(log)
    assert main(["compare", str(out), "--force"]) == 2
    err = capsys.readouterr().err
    assert str(lock_path(out)) in err and "not a lock file" in err
    assert log.read_bytes() == LOG
    with pytest.raises(OutputExistsError, match="not a lock file"), \
            locked(out, "evtribo compare"):
        pass
    assert log.read_bytes() == LOG


def test_a_lock_file_that_is_a_second_name_of_a_log_is_never_written(share):
    out = share / "out"
    log = share / "study" / "P01" / "a80.log"
    os.link(log, lock_path(out))
    with pytest.raises(OutputExistsError, match="2 names"), locked(out, "evtribo compare"):
        pass
    assert log.read_bytes() == LOG
