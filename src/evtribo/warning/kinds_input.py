"""The kinds of warning about a study's inputs: its folder (logs, sidecars, re-recordings,
files changed since the analysis), the logs' lines, the frames decoded from them, the
logger's clock and the load cells' counters and lost frames."""

from __future__ import annotations

from evtribo.warning.kind import Kind

__all__ = ["INPUT_KINDS"]

_FOLDER = (
    Kind("log-part-superseded", "information", "an unfinished log beside the trial's complete one",
         "{part}: not analysed, {complete} is the trial's complete log (the .part is a "
         "recording that did not finish, e.g. a --force re-recording that was killed); "
         "nothing was deleted",
         "Nothing to do for the results; remove the .part file once you no longer need what "
         "it holds.", "trial", prefixed=False),
    Kind("rerecording-unfinished", "information", "a re-recording (--force) that did not finish",
         "{stage}: a re-recording of trial {trial} (--force) that did not finish; not "
         "analysed (the trial is the one recorded before it); what it received is kept there",
         "Record the trial again (evtribo acquire --force) if the one recorded before is not "
         "the one you want analysed.", "trial", prefixed=False),
    Kind("rerecording-leftover", "information", "files left of a trial recorded again",
         "{path}: not analysed, left of the recording {trial} was recorded again over "
         "(--force)",
         "Nothing to do for the results; the file is what the trial's earlier recording "
         "left.", "trial", prefixed=False),
    Kind("sidecar-unknown-key", "information", "a sidecar key evtribo does not know",
         "{sidecar}: unknown key {key!r} ignored{suggestion}",
         "Correct the key's name in the sidecar (the suggestion, where one is given) or "
         "remove it.", "trial", prefixed=False),
    Kind("sidecar-missing", "information", "a log without its sidecar",
         "{log}: no sidecar {trial}.json; condition and amplitude must come from the "
         "excitation signals",
         "Write the trial's sidecar (condition, waveform, frequency, amplitude) if the rig "
         "has no excitation signals that say them.", "trial", prefixed=False),
    Kind("log-partial", "information", "a partial log (acquisition did not finish)",
         "{log}: partial trial (acquisition did not finish); analysing what was recorded",
         "Check that what was recorded is enough for the trial, or record it again.",
         "trial", prefixed=False),
    Kind("cut-short", "information", "recordings cut short (what was recorded analysed)",
         "{log}: the recording was {ended}{after}; analysing what was recorded",
         "Check that what was recorded is enough for the trial, or record it again.",
         "trial", prefixed=False),
    Kind("sidecar-without-log", "information", "a sidecar without a log",
         "{sidecar}: sidecar without a log{besides}; not analysed",
         "Put the trial's log beside its sidecar (in a format evtribo reads), or remove the "
         "sidecar.", "trial", prefixed=False),
    Kind("subject-outside", "information", "a subject folder linked from outside the study",
         "{folder}: a link to {target}, outside the study folder: its trials are analysed as "
         "subject {subject}'s; copy them into the study if they belong to it (or remove the "
         "link)",
         "Copy the subject's trials into the study folder if they belong to it, or remove "
         "the link.", "subject", prefixed=False),
    Kind("input-changed", "number", "inputs changed since the analysis",
         "{file}: changed since the analysis (sha256 {then}... then, {now}... now): these "
         "results are not of the study as it is now; analyse it again",
         "Analyse the study again (evtribo analyze) so that the results are of its files as "
         "they are.", "trial", prefixed=False,
         stands_for=("input-added", "input-unreadable")),
    Kind("input-added", "number", "trials added since the analysis",
         "{file}: in the study folder but not in the analysis (added since?)",
         "Analyse the study again (evtribo analyze) to include the trial.", "trial",
         prefixed=False),
    Kind("input-unreadable", "number", "inputs that cannot be read now",
         "{file}: cannot read it now ({error}): whether it changed since the analysis is not "
         "known",
         "Make the file readable again to know whether these results are of the study as it "
         "is.", "trial", prefixed=False),
    Kind("input-gone", "information", "inputs no longer in the study folder",
         "{file}: no longer in the study folder {study_dir} (it was an input of the "
         "analysis)",
         "Nothing to do for these results; analyse the study again if the file was removed "
         "on purpose.", "trial", prefixed=False),
    Kind("inputs-outside", "information", "inputs named outside the study folder",
         "summary.json names {files} input file(s) outside the study folder: not listed, "
         "not read (summary.json was edited?)",
         "Analyse the study again (evtribo analyze) to have a summary.json of its own.",
         "study"),
    Kind("trials-unlisted", "information", "the study's trials cannot be listed now",
         "cannot list the study's trials now: {error}",
         "Check that the study folder is there and readable.", "study"),
    Kind("input-changed-during", "information", "inputs changed during the analysis",
         "{file}: changed during the analysis; the results are of the file as it was when "
         "the analysis started (sha256 {sha256}...)",
         "Analyse the study again once nothing writes into it.", "trial", prefixed=False),
)

_LINES = (
    Kind("damaged-line", "information", "a damaged log line skipped",
         "{where}: skipped damaged line: {reason}",
         "Nothing to do if few lines are damaged; otherwise look at how the log was written "
         "(the line named).", "trial"),
    Kind("damaged-lines-more", "information", "damaged log lines skipped in all",
         "{log}: {lines} damaged lines skipped in all (first {listed} listed)",
         "Look at how the log was written: many of its lines are damaged.", "trial"),
    Kind("damaged-lines", "information", "damaged log lines skipped",
         "{lines} damaged line(s) skipped in {log}",
         "Nothing to do if few lines are damaged; otherwise look at how the log was "
         "written.", "trial",
         stands_for=("damaged-line", "damaged-lines-more")),
    Kind("candump-deltas", "information", "times rebuilt from candump -td's deltas",
         "{log}: candump -td log: times rebuilt by adding up {deltas} deltas, each printed "
         "rounded down to 1 {unit}: the last frames may be early by up to {deltas} "
         "{unit}{lost}; record with candump -L for exact times",
         "Record with candump -L (or -ta) for exact times.", "trial"),
    Kind("cache-unwritable", "information", "a decoded trial not cached",
         "{cache}: cannot write the cache entry ({error}); the trial is decoded but not "
         "cached",
         "Make the cache folder writable (or set EVTRIBO_CACHE_DIR) to decode each trial "
         "once.", "trial"),
    Kind("dbc-lenient", "information", "a DBC read leniently",
         "{dbc}: {why}; decoding it anyway",
         "Correct the DBC so that it parses strictly (the fault named).", "study",
         prefixed=False),
)

_FRAMES = (
    Kind("frames-short", "information", "frames shorter than their message",
         "{frames} frames of {message} (0x{frame_id:X}) are shorter than its {length} bytes: "
         "not decoded",
         "Check the message's length in the DBC against what the rig sends.", "trial"),
    Kind("frames-undecoded", "information", "frames no signal of which can be decoded",
         "{frames} frames of {message} (0x{frame_id:X}) not decoded: {reason}",
         "Correct the message in the DBC (the fault named).", "trial"),
    Kind("frames-decode-failed", "information", "frames that could not be decoded",
         "{frames} frames of {message} (0x{frame_id:X}) could not be decoded (first, frame "
         "{first}: {reason}): their signals are NaN",
         "Check the message's multiplexing in the DBC against what the rig sends.", "trial"),
    Kind("frames-id-kind", "information", "frames of a message's ID number, another kind of ID",
         "{frames} frames have the {id_seen}, but the DBC's message {message} has the "
         "{id_declared}: not decoded as {message} (the kind of ID is part of it)",
         "Check whether the message's ID is standard or extended, in the DBC and on the "
         "rig.", "trial"),
    Kind("frames-fd-kind", "information", "frames of a message's ID, CAN FD against classic",
         "{frames} {kind_seen} frames have the {id_text} of the DBC's {kind_declared} message "
         "{message}: not decoded as {message}, counted with the frames the DBC does not "
         "describe (a CAN FD frame is only an FD message, a classic frame only a classic "
         "one)",
         "Check whether the message is CAN FD or classic, in the DBC and on the rig.",
         "trial"),
    Kind("timestamps-nonfinite", "information", "frames without a clock's timestamp",
         "{frames} frames with a timestamp that is not a finite number or is 2^63 or more "
         "(no clock's): not decoded",
         "Look at how the log was written: its timestamps are damaged.", "trial"),
    Kind("channels-several", "information", "the rig's messages on several channels",
         "the rig's messages arrive on several channels ({counts}){shared}: decoded from "
         "{channel}{chosen}; the others are ignored, never merged (choose with "
         "channel=...)",
         "Choose the channel the rig's frames are decoded from if it is not the one named.",
         "trial"),
    Kind("counter-elsewhere", "information", "a counter outside its force's message",
         "counter {counter} is not in the force's message {message}: timing gaps only",
         "Name a counter of the force's own message in the rig file, or none.", "trial"),
    Kind("waveform-codes", "information", "waveform codes read without a value table",
         "the DBC gives the waveform signal {signal} no value table: its codes are read as "
         "{codes}",
         "Give the waveform signal a value table (VAL_) in the DBC.", "trial"),
    Kind("samples-range-wrong", "information", "samples outside the DBC's range, kept",
         "{share:.0%} of the samples of {signal} are outside the DBC's declared range "
         "{range}: kept, the range is wrong for this sensor (fix the DBC's range)",
         "Correct the signal's range in the DBC.", "trial"),
    Kind("samples-bad", "information", "bad samples left out",
         "{samples} samples of {signal} are no number or outside the DBC's declared range "
         "{range} (the first at {at_s:.3f} s into the trial: {value:.3g}): left out as bad "
         "samples",
         "Nothing to do if they are few; otherwise check the sensor and the signal's range "
         "in the DBC.", "trial"),
)

_CLOCK = (
    Kind("clock-step", "information", "the logger's clock stepped",
         "the logger's clock stepped {direction} by {step_s:.3f} s at {at_s:.3f} s into the "
         "trial: the frames after it are put back on the clock of those before (the load "
         "cells' counters say no time passed there)",
         "Nothing to do; a logger whose clock is not set while it records steps no more.",
         "trial"),
    Kind("counter-restart", "information", "a load cell's counter restarted",
         "the counter {counter} restarted at 0 at {at_s:.3f} s into the trial: {lost} "
         "frame{lost:plural} lost there, by the timing, not the counter's step",
         "Nothing to do; check the load cell's power and cabling if it happens often.",
         "trial"),
    Kind("counter-jump", "information", "a load cell's counter jumped",
         "the counter {counter} jumped from {old} to {new} at {at_s:.3f} s into the trial: "
         "{lost} frame{lost:plural} lost there, by the timing, not the counter's step",
         "Nothing to do; check the load cell's power and cabling if it happens often.",
         "trial"),
    Kind("frames-twice", "information", "frames received twice",
         "{frames} frame{frames:plural} of {message} received twice, the first at "
         "{at_s:.3f} s into the trial (the counter and the payload of a frame just before): "
         "dropped, counted in duplicate_frames",
         "Nothing to do; check the logger or the bus if many frames arrive twice.", "trial"),
    Kind("counter-stood", "information", "a load cell's counter stood still",
         "the counter {counter} stood still for {frames} frames, the first at {at_s:.3f} s "
         "into the trial (the value of the frame before, another payload): each taken for "
         "the next frame, not 255 lost",
         "Nothing to do; check the load cell's firmware if its counter often stands still.",
         "trial"),
    Kind("counter-idle", "information", "a load cell's counter that does not count",
         "the counter {counter} does not count ({why}): it is ignored, and the frames lost "
         "are counted from the timestamps",
         "Name no counter for this cell in the rig file, or check the cell's firmware.",
         "trial"),
    Kind("counter-law", "information", "a load cell's counter as its firmware counts",
         "the counter {counter} counts {counts} and starts again, every {period} frames, "
         "not {width} as its {bits} bits allow: its period is taken from the timing "
         "(declare it in the rig file, [rig] {key} = {period}, to make it certain)",
         "Declare the counter's period in the rig file (the key and value named).", "trial",
         stands_for=("counter-idle", "counter-law-rate", "counter-period-unsure")),
    Kind("counter-law-rate", "information", "a counter's period learnt from the bus's rate",
         "the counter {counter} counts {counts} and starts again, every {period} frames, "
         "not {width} as its {bits} bits allow (counting to its top, the cell would send "
         "{rate_Hz:,.0f} frames a second, more than a CAN bus carries; declare its period in "
         "the rig file, [rig] {key} = {period}, to make it certain)",
         "Declare the counter's period in the rig file (the key and value named).", "trial"),
    Kind("counter-period-unsure", "information", "a counter's period the timing cannot tell",
         "the counter {counter} never counted {width} in this trial (it counts {counts} and "
         "starts again), and the timestamps cannot tell whether its firmware starts again "
         "there or the frames between were lost each time: counted as lost; if it counts "
         "{counts}, declare it in the rig file ([rig] {key} = {period})",
         "Declare the counter's period in the rig file if it counts as named; the frames "
         "lost are otherwise overcounted.", "trial"),
)

_LOST = (
    Kind("frames-lost", "information", "load-cell frames lost",
         "{frames} dropped frame(s)",
         "Nothing to do if they are few; otherwise lower the bus's load or use a logger that "
         "keeps up.", "trial",
         stands_for=("frames-lost-periods", "frames-dropcount", "counter-overcounts",
                     "frames-lost-outages", "frames-lost-unseen", "frames-lost-clock")),
    Kind("frames-lost-periods", "information", "whole counter periods lost at once",
         "{cell} force: {frames} frames missing, including whole counter periods lost at "
         "once (found from the timing)",
         "Nothing to do if they are few; check the logger and the bus's load otherwise.",
         "trial"),
    Kind("frames-dropcount", "information", "frames the recording tool dropped",
         "the recording tool dropped {frames} frames on this channel (DROPCOUNT)",
         "Lower the bus's load or give the recording tool a larger receive queue.",
         "trial"),
    Kind("counter-overcounts", "information", "a counter that counts more lost than the time holds",
         "{cell} force: the counter counts {counted} frames lost where the stream's "
         "{span_s:.3f} s hold {held} at most at its rate ({rate_Hz:.0f} Hz): it does not "
         "count every frame; counted from the timestamps, and the counter ignored",
         "Check the counter's period in the rig file, or name no counter for this cell.",
         "trial"),
    Kind("frames-lost-outages", "information", "lost frames counted as outages only",
         "{cell} force: timestamps too irregular ({bursts}coherence {coherence:.2f}) to see "
         "single lost frames without a counter: only outages of {frames} or more frames in a "
         "row, away from the trial's ends, are counted",
         "Use a logger with hardware timestamps, or a load cell with a counter, to count "
         "every lost frame.", "trial"),
    Kind("frames-lost-unseen", "information", "lost frames not countable in a short stream",
         "{cell} force: timestamps too irregular ({bursts}coherence {coherence:.2f}) to see "
         "single lost frames without a counter, and too few frames ({frames}) to see an "
         "outage: none counted",
         "Use a logger with hardware timestamps, or a load cell with a counter, to count "
         "every lost frame.", "trial"),
    Kind("frames-lost-clock", "information", "frames lost where the clock jumped",
         "{cell} force: the clock {jumped} by more than {jump_s:g} s; frames missing across "
         "it {counted}",
         "Nothing to do; a logger whose clock is not set while it records jumps no more.",
         "trial"),
    Kind("periods-unsure", "information", "whole counter periods perhaps lost in pauses",
         "{cell} force: whole counter periods may have been lost in the pause(s) of "
         "{pauses} (the counter repeats every {period} frames; the timing cannot tell): "
         "counted by the counter alone",
         "Nothing to do if the pauses are few; a counter of a longer period tells more.",
         "trial"),
    Kind("periods-unsure-still", "information",
         "whole counter periods perhaps lost where the timestamps stand still",
         "{cell} force: whole counter periods may have been lost in the pauses (the "
         "timestamps stand still between them; the timing cannot tell): counted by the "
         "counter alone",
         "Look at how the logger stamps the frames: its timestamps stand still.", "trial"),
)

#: The inputs' kinds, in the order the documentation lists them.
INPUT_KINDS: tuple[Kind, ...] = (*_FOLDER, *_LINES, *_FRAMES, *_CLOCK, *_LOST)
