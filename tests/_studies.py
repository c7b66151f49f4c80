"""The one way a test builds a study folder on disk."""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from evtribo import study

#: A log of one frame, enough for discovery (no DBC is read).
ONE_FRAME = "(1.000000) vcan0 0C1#00\n"


def make_study(root: Path, trials: Mapping[str, Mapping[str, Any] | None], *,
               rig: Mapping[str, Any], name: str = "sweep", log: str = ONE_FRAME,
               dbc: Path | None = None) -> Path:
    """Write a study folder and return it.

    Parameters
    ----------
    root : Path
        The study folder (created).
    trials : mapping
        ``{"SUBJECT/TRIAL": sidecar}``: each trial gets *log* as ``TRIAL.log`` and, unless
        its sidecar is None, ``TRIAL.json``.
    rig : mapping
        The ``[rig]`` table of ``study.toml``.
    name : str
        The study's ``name``.
    log : str
        Every trial's log.
    dbc : Path, optional
        A DBC copied to where ``rig["dbc"]`` says.

    Returns
    -------
    Path
        *root*.
    """
    study.write_study_toml(root, name=name, rig=rig)
    if dbc is not None:
        (root / rig["dbc"]).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(dbc, root / rig["dbc"])
    for key, sidecar in trials.items():
        subject, trial = key.split("/")
        (root / subject).mkdir(exist_ok=True)
        (root / subject / f"{trial}.log").write_text(log, encoding="utf-8")
        if sidecar is not None:
            (root / subject / f"{trial}.json").write_text(json.dumps(sidecar),
                                                          encoding="utf-8")
    return root
