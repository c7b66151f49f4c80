"""``evtribo decode LOG --dbc F -o OUT.mf4``: read back by asammdf, the same values as the
Parquet table of the same log, with the DBC's units, comments and value tables."""

from __future__ import annotations

import tempfile
from pathlib import Path

import cantools
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from test_decode_stream import DBC, logs

from evtribo.cli import main
from evtribo.store.owned import MANIFEST

asammdf = pytest.importorskip("asammdf")

STUDY = Path(__file__).parents[2] / "data" / "reference-study"
SINE_LOG = STUDY / "P01" / "run-06.log.gz"
RIG_DBC = STUDY / "rig" / "default.dbc"


def _groups(path: Path) -> dict[str, tuple[np.ndarray, dict[str, object]]]:
    """Each channel group of an MF4 by its acquisition name: its times and its signals."""
    out = {}
    with asammdf.MDF(path) as mdf:
        start = mdf.header.start_time.timestamp()
        for gi, group in enumerate(mdf.groups):
            names = [c.name for c in group.channels[1:]]
            signals = {n: mdf.get(n, gi, raw=True) for n in names}
            signals |= {f"{n}:text": mdf.get(n, gi) for n in names}
            t = next(iter(signals.values())).timestamps
            out[group.channel_group.acq_name] = (t, {"start": start, **signals})
    return out


def _compare(mf4: Path, table: pd.DataFrame, dbc: cantools.database.can.Database) -> int:
    """Assert that every message's rows of *table* are its group in *mf4*; the rows."""
    groups = _groups(mf4)
    seen = 0
    for message in dbc.messages:
        rows = table[table["message"] == message.name]
        if rows.empty:
            assert message.name not in groups
            continue
        t, signals = groups[message.name]
        # the times: exactly the log's less the header's start, a whole second
        assert signals["start"] == int(signals["start"])
        np.testing.assert_array_equal(t, rows["timestamp"].to_numpy(float) - signals["start"])
        for sig in message.signals:
            column = sig.name if sig.name in rows.columns else f"{message.name}.{sig.name}"
            got = signals[sig.name]
            np.testing.assert_array_equal(got.samples, rows[column].to_numpy(float))
            assert got.unit == (sig.unit or "")
            assert got.comment == (sig.comment or "")
            if sig.choices:  # the value table: each code's name, as cantools gives it
                text = signals[f"{sig.name}:text"].samples
                codes = (rows[column].to_numpy(float) - sig.offset) / sig.scale
                for code, name in zip(codes, text, strict=True):
                    if np.isfinite(code) and round(code) in sig.choices:
                        assert name.decode() == str(sig.choices[round(code)])
        seen += len(rows)
    assert seen == len(table)
    return seen


def test_a_sine_trial_round_trips_through_asammdf(tmp_path, capsys):
    mf4, parquet = tmp_path / "run-06.mf4", tmp_path / "run-06.parquet"
    args = [str(SINE_LOG), "--dbc", str(RIG_DBC)]
    assert main(["decode", *args, "-o", str(mf4)]) == 0
    assert "3 channel groups (one per message)" in capsys.readouterr().out
    assert main(["decode", *args, "-o", str(parquet)]) == 0
    dbc = cantools.database.load_file(RIG_DBC)
    table = pd.read_parquet(parquet)
    assert _compare(mf4, table, dbc) > 10_000
    with asammdf.MDF(mf4) as mdf:  # the log's first frame is the measurement's start
        first = table["timestamp"].iloc[0]
        assert first - 1 < mdf.header.start_time.timestamp() <= first
        waves = set(mdf.get("HvWave").samples)
        assert waves == {b"sine"}  # the value table's name, as asammdf's GUI shows it
    assert not [p for p in tmp_path.iterdir()  # no temporary file left
                if p.name.startswith(".") and p.name != MANIFEST]


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(lines=logs())
def test_any_log_round_trips_through_asammdf(lines):
    """Mixed lengths, extended IDs, two buses, damaged lines, a value table: the MF4 holds
    the rows the Parquet table holds, value for value."""
    dbc = cantools.database.load_string(DBC, "dbc")
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        (folder / "rig.dbc").write_text(DBC)
        (folder / "a.log").write_text("\n".join(lines) + "\n")
        args = [str(folder / "a.log"), "--dbc", str(folder / "rig.dbc")]
        readable = main(["decode", *args, "-o", str(folder / "a.parquet")]) == 0
        table = pd.read_parquet(folder / "a.parquet") if readable else pd.DataFrame()
        code = main(["decode", *args, "-o", str(folder / "a.mf4")])
        if table.empty:  # no log, or nothing to write: refused, and nothing written
            assert code == 2 and not (folder / "a.mf4").exists()
        else:
            assert code == 0
            _compare(folder / "a.mf4", table, dbc)


def test_force_replaces_an_mf4_evtribo_wrote_never_a_raw_can_log(tmp_path, capsys):
    import can

    raw = tmp_path / "bus.mf4"  # a raw CAN log as python-can (and CANape) write it
    with can.Logger(raw) as writer:
        for i in range(3):
            writer.on_message_received(can.Message(timestamp=1763700000 + i * 1e-3,
                                                   arbitration_id=0xC1, is_extended_id=False,
                                                   data=bytes(8)))
    before = raw.read_bytes()
    ours = tmp_path / "signals.mf4"
    args = [str(SINE_LOG), "--dbc", str(RIG_DBC)]
    assert main(["decode", *args, "-o", str(ours)]) == 0
    assert main(["decode", *args, "-o", str(ours)]) == 2  # exists
    assert main(["decode", *args, "-o", str(ours), "--force"]) == 0
    assert main(["decode", *args, "-o", str(raw), "--force"]) == 2
    assert "is a CAN log" in capsys.readouterr().err
    assert raw.read_bytes() == before
