"""The sentences evtribo's sites said before their wordings moved into the warning catalogue,
as their functions said them (byte for byte): tests/warning/test_warning_wordings.py holds
each site's records to them."""

from __future__ import annotations

#: By case, the sentences (a list where the site said several).
SAID: dict[str, str | list[str] | None] = {
    "seq-0.018": [
        ("the logger's clock stepped back by 0.018 s at 12.000 s into the trial: the "
         "frames after it are put back on the clock of those before (the load cells' "
         "counters say no time passed there)"),
        ("the counter FzCell.FzCounter restarted at 0 at 13.000 s into the trial: 1 "
         "frame lost there, by the timing, not the counter's step"),
        ("1 frame of FzCell received twice, the first at 10.000 s into the trial (the "
         "counter and the payload of a frame just before): dropped, counted in "
         "duplicate_frames"),
        ("the counter FzCell.FzCounter stood still for 4 frames, the first at 11.500 "
         "s into the trial (the value of the frame before, another payload): each "
         "taken for the next frame, not 255 lost"),
    ],
    "seq2.5": [
        ("the logger's clock stepped ahead by 2.500 s at 12.000 s into the trial: the "
         "frames after it are put back on the clock of those before (the load cells' "
         "counters say no time passed there)"),
        ("the counter FzCell.FzCounter jumped from 17 to 45 at 13.000 s into the "
         "trial: 3 frames lost there, by the timing, not the counter's step"),
        ("3 frames of FzCell received twice, the first at 10.000 s into the trial "
         "(the counter and the payload of a frame just before): dropped, counted in "
         "duplicate_frames"),
        ("the counter FzCell.FzCounter stood still for 4 frames, the first at 11.500 "
         "s into the trial (the value of the frame before, another payload): each "
         "taken for the next frame, not 255 lost"),
    ],
    "law0.12": ("P02: the OFF windows' normal forces span too little to tell how the "
        "friction grows with the load (m = 0.93 [0.67, 1.19]; F_t = c W^m, a finger "
        "pad's m is 0.67-0.9): electrostatic_force_N is Amontons' (m = 1), and "
        "electrostatic_force_m075_N gives F_el at m = 0.75, higher by about a third; "
        "OFF phases at two or three target presses measure m (docs/analysis.md, \"The "
        "friction law\")"),
    "lawnan": ("P02: the OFF windows' normal forces span too little to tell how the "
        "friction grows with the load (no spread of the normal force to fit m to; "
        "F_t = c W^m, a finger pad's m is 0.67-0.9): electrostatic_force_N is "
        "Amontons' (m = 1), and electrostatic_force_m075_N gives F_el at m = 0.75, "
        "higher by about a third; OFF phases at two or three target presses measure "
        "m (docs/analysis.md, \"The friction law\")"),
    "drift": [
        ("P01: the friction coefficient changed within 2 of 3 trials (by -20 % over "
         "trial run-03; falling in 1, at a constant stroke pace and press: a "
         "fingertip moistening or drying); each ON window was compared with its "
         "trial's OFF friction at its own time (mu_change_per_10s in trials.csv)"),
        ("P01: the friction coefficient changed within 2 of 3 trials (by -20 % over "
         "trial run-03; falling in 1, at a constant stroke pace and press: a "
         "fingertip moistening or drying); trials run-04, run-05 are ON throughout "
         "and were compared with other trials' OFF windows, so such a change goes "
         "into their electrostatic force unseen: alternate ON and OFF within each "
         "trial"),
    ],
    "scatter": [
        ("P01: the OFF windows' friction coefficient scatters by 8 % between strokes "
         "(speed, posture) beyond what the strokes' pace explains; the intervals "
         "include it: strokes of an even pace and length narrow them"),
    ],
    "pace": [
        ("P01: the friction follows the strokes' pace (faster strokes, other "
         "friction); the ON strokes were 25 % slower than the OFF ones; each ON "
         "window was compared with the OFF friction at its own stroke's pace "
         "(docs/analysis.md, \"Speed and direction\")"),
    ],
    "phases": [
        ("P03: in trials run-01, run-02 the ON and OFF phases are too long to tell a "
         "drift of the friction (a moistening finger) from the voltage's effect: "
         "fitting the drift widens F_el's interval up to 3.0-fold, and a drift the "
         "data do not show clearly goes into F_el; with trials of 60 s, phases of "
         "14.5 s or shorter keep the two apart"),
    ],
    "implausible": [
        ("P01: friction coefficient 2.30, outside what fingers give on glass "
         "(0.05-1.5): the roles normal_force and tangential_force in study.toml may "
         "be swapped, or a cell's scale in the DBC wrong; the electrostatic forces "
         "rest on it"),
    ],
    "negative": [
        ("P01: the electrostatic force is below zero beyond chance at 60 V, 80 V "
         "(Holm's test over the study's 2 cells at 5 %: the voltage lowered the "
         "friction): the roles in study.toml may be swapped, the excitation's ON/OFF "
         "signal inverted, or a sidecar's condition wrong"),
    ],
    "crosstalk": [
        ("the normal cell reads +5.1 % (+/- 0.1, over 4 trials) of the tangential "
         "force: its reading jumps with each reversal of the strokes; cross-talk, or "
         "a finger pressing harder one way. The electrostatic force weighs both "
         "directions alike and is not biased by it, but the normal forces reported "
         "are: give [rig.calibration] matrix = [[1.0, -0.0505], [0.0, 1.0]] in "
         "study.toml, or measure the whole matrix with evtribo calibrate"),
        ("the tangential reading follows the normal force by +3.0 % of it in both "
         "sliding directions (4 trials): cross-talk from the normal axis, or friction "
         "that differs between the directions; the electrostatic force compares each "
         "direction with its own friction. evtribo calibrate on a recording of the "
         "finger pressing without sliding tells the two apart"),
    ],
    "noforce": [
        ("no electrostatic force: no trial has an ON window (40 OFF windows: the "
         "trials' condition is off, or the amplifier's status never said ON); evtribo "
         "report shows each subject's μ"),
        ("no electrostatic force: no subject has both ON and OFF windows with a known "
         "amplitude; evtribo report shows each subject's μ"),
    ],
    "like": [
        ("4 of 4 ON windows are left out: the OFF windows all slid forwards, and with "
         "the tangential cell's zero unknown an ON window sliding the other way "
         "differs from them by twice the cell's offset besides the voltage's effect "
         "(the electrostatic force cannot be told from the offset); record a tare "
         "stretch (evtribo acquire --tare-s), give [rig.calibration] "
         "tangential_offset_N, or slide both ways in each phase"),
    ],
    "clock": ("the clock jumped ahead or paused by more than 1 s; frames missing across it "
        "cannot be counted"),
    "outages": ("timestamps too irregular (frames received in bursts, coherence 0.42) to see "
        "single lost frames without a counter: only outages of 2 or more frames in a "
        "row, away from the trial's ends, are counted"),
    "idle": ("the counter FzCell.FzCounter does not count (it stays at 5): it is ignored, "
        "and the frames lost are counted from the timestamps"),
    "bad": ("2 samples of FzCell.Fz are no number or outside the DBC's declared range "
        "[0, 50] N (the first at 9.980 s into the trial: inf): left out as bad "
        "samples"),
    "range": ("100% of the samples of FzCell.Fz are outside the DBC's declared range [0, "
        "50] N: kept, the range is wrong for this sensor (fix the DBC's range)"),
}
