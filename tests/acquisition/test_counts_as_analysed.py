"""The recorder counts a load cell's lost frames as the analysis counts them in the log it
wrote: the sidecar's ``dropped_frames`` is ``evtribo analyze``'s, whatever the counter's law
(any period from 2 to its width's, declared in the rig file or not, by 1 or 2, from 0 or 1,
or stuck) and whatever the frames went through (lost one by one or in runs, the counter's
top values lost at every wrap, received twice, late, a firmware that restarts its counter at
a low value or any other after a silence, stamped one by one or in an adapter's polls).
While it records, its count is never thousands of frames a counter's period makes up: where
it cannot know yet (a period not learnt in the counter's first wraps) the live display says
so."""

from __future__ import annotations

import tempfile
import tomllib
from pathlib import Path

import can
import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from evtribo.acquisition.counters import CounterTracker
from evtribo.acquisition.logger import LogWriter
from evtribo.acquisition.rigfile import AcquisitionRig
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.io import read_frames
from evtribo.canlog.rig import Rig, default_rig_path

CELLS = {"FzCell": 0x0C1, "FxCell": 0x0C2}


def _rig(period: int | None) -> Rig:
    """The default rig; its rig file declaring the counters' *period* (None: not)."""
    table = tomllib.loads(default_rig_path().read_text(encoding="utf-8"))
    if period is not None:
        table |= {"normal_force_counter_period": period,
                  "tangential_force_counter_period": period}
    return Rig.from_mapping(table, default_rig_path().parent)


@st.composite
def _laws(draw):
    """A counter's law as firmware has them: (period, step, start), or None: stuck at 0."""
    if draw(st.integers(0, 5)) == 0:
        return None
    step = draw(st.sampled_from([1, 1, 2]))
    start = draw(st.sampled_from([0, 0, 1]))
    period = draw(st.one_of(st.integers(2, (256 - start) // step),
                            st.sampled_from([10, 15, 100, 250, 256])))
    assume(start + step * (period - 1) <= 255)
    return period, step, start


@st.composite
def _faults(draw, period: int, n: int):
    """What one cell's frames go through (see :func:`_cell`), drawn."""
    restart = draw(st.one_of(st.none(), st.tuples(
        st.integers(n // 4, 3 * n // 4),                              # at this frame
        st.one_of(st.integers(0, max(period // 8, 1)), st.integers(0, period - 1)),
        st.integers(0, 20))))                                         # periods silent
    lost = draw(st.sets(st.integers(1, n - 2), max_size=8))
    outage = draw(st.one_of(st.none(), st.tuples(st.integers(1, n - 300),
                                                 st.integers(2, min(period + 40, 280)))))
    top = draw(st.integers(0, 3)) if period >= 8 and draw(st.integers(0, 3)) == 0 else 0
    received = draw(st.lists(st.tuples(st.integers(2, n // 2), st.booleans(),
                                       st.integers(0, 3)), max_size=4))
    return restart, lost, outage, top, received


def _cell(law, rate: float, n: int, faults):
    """One cell's frames as received: (send time in s, counter value, frame number) each,
    the frames lost (one by one, in a run, or the counter's *top* values at every wrap),
    some received twice or late, the firmware restarting once; the frames truly lost, and
    whether it restarted."""
    period, step, start = law or (256, 1, 0)
    restart, lost, outage, top, received = faults
    places = np.arange(n)
    send = places / rate
    if restart is not None:
        at, new, silent = restart
        places = np.where(places < at, places, new + places - at)
        send = send + np.where(np.arange(n) >= at, silent / rate, 0.0)
    counter = np.zeros(n, np.int64) if law is None else start + step * (places % period)
    lost = set(lost)
    if outage is not None:
        lost |= set(range(outage[0], outage[0] + outage[1]))
    if top and law is not None:
        lost |= set(np.flatnonzero(counter > start + step * (period - 1 - top)).tolist())
    frames = [(float(send[k]), int(counter[k]), k) for k in range(n) if k not in lost]
    for i, twice, later in sorted(received, reverse=True):
        if i + 5 >= len(frames):
            continue
        if twice:  # received again a few frames later, stamped as the frame it follows
            frames.insert(i + later + 1, (frames[i + later][0], *frames[i][1:]))
        elif frames[i][2] + 1 == frames[i + 1][2]:  # late: after the frame sent after it
            frames[i], frames[i + 1] = frames[i + 1], frames[i]
    return frames, len(lost), restart is not None


@st.composite
def _trials(draw):
    law = draw(_laws())
    declared = law is not None and draw(st.booleans())
    rate = draw(st.sampled_from([1000.0, 2000.0]))
    n = draw(st.integers(1500, 3000))
    faults = {name: draw(_faults((law or (256,))[0], n)) for name in CELLS}
    poll = draw(st.sampled_from([0.0, 0.0, 1e-3, 8e-3]))
    jitter = draw(st.floats(0.0, 0.2))
    return law, declared, rate, n, faults, poll, jitter


def _messages(cells, rate: float, poll: float, jitter: float, seed: int
              ) -> list[can.Message]:
    """Both cells' frames as a logger gives them: stamped when received (late by a jitter
    of up to *jitter* periods, or at the end of the adapter's *poll*), in that order."""
    rng = np.random.default_rng(seed)
    out = []
    for name, (frames, _, _) in cells.items():
        t = np.array([f[0] for f in frames]) + rng.uniform(0, jitter / rate, len(frames))
        t = 1.76e9 + np.maximum.accumulate(t)  # stamped as received: in order
        if poll:
            t = np.ceil(t / poll) * poll
        for (_, counter, k), ts in zip(frames, t, strict=True):
            force = int(20_000 + 37 * k % 4001).to_bytes(3, "little")
            out.append((float(ts), CELLS[name], force + bytes(4) + bytes([counter])))
    out.sort(key=lambda m: m[0])
    return [can.Message(timestamp=ts, arbitration_id=ident, is_extended_id=False, data=data)
            for ts, ident, data in out]


def _not_known(stats, name: str) -> bool:
    return "not known yet" in stats.counters.get(name, "")


def _check_live(stats, cells, law) -> None:
    """While it records, a cell's count is not known yet, or no more than the frames lost
    and a restart's step still waiting for the frames after it (never a counter's period
    made up at every wrap)."""
    if law is None or law[0] < 8:  # the timestamps' count, as the analysis's; a shorter
        return                     # period cannot tell a frame lost from a whole period
    for name, (_, lost, restarted) in cells.items():
        if not _not_known(stats, name):
            shown = stats.dropped_by_message.get(name, 0)
            assert shown <= lost + 2 + (2 * law[0] if restarted else 0), (name, shown, lost)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trial=_trials(), batch=st.integers(50, 500), seed=st.integers(0, 2**32 - 1))
def test_the_recorder_counts_the_frames_lost_as_the_analysis_of_its_log(trial, batch, seed):
    law, declared, rate, n, faults, poll, jitter = trial
    cells = {name: _cell(law, rate, n, f) for name, f in faults.items()}
    rig = _rig(law[0] if declared else None)
    messages = _messages(cells, rate, poll, jitter, seed)
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "run-01.log"
        with log.open("wb", buffering=0) as fh:
            writer = LogWriter(fh, "vcan0", CounterTracker(AcquisitionRig.from_rig(rig).counters))
            for a in range(0, len(messages), batch):
                writer._write(messages[a:a + batch])
                _check_live(writer.stats, cells, law)
            writer._settle()
        signals = decode_trial(read_frames(log)[0], rig)
    stats = writer.stats
    analysed = {"FzCell": signals.normal, "FxCell": signals.tangential}
    assert stats.dropped_by_message == {name: cell.dropped for name, cell in analysed.items()}
    assert stats.dropped == signals.dropped_frames
    assert stats.duplicates == signals.duplicate_frames
    assert not any(_not_known(stats, name) for name in CELLS)  # settled once the log closed
    notes = writer.counters.notes_by_message()  # the sidecar's counter_notes
    said = {w.text for w in signals.warnings}  # the decoder's warnings, as records
    assert set(notes.values()) <= said, (notes, said)
    if law is None:  # said plainly, and no loss counted from it
        assert all("does not count" in stats.counters[name] for name in CELLS), stats.counters
