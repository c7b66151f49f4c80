"""The kinds of warning about a study's results: the trials gathered per subject (the OFF
references, the friction law, drifts and the strokes' pace), each drive's power law, each
cell's windows, what no finger gives, the load cells' cross-talk over the study."""

from __future__ import annotations

from evtribo.warning.kind import Kind

__all__ = ["STUDY_KINDS"]

_DRIFT = ("the friction coefficient changed within {changed} of {trials} trials (by "
          "{change_pct:+.0f} % over trial {worst}; {direction} in {same}, at a constant stroke "
          "pace and press: a fingertip moistening or drying)")

_FORCE = (
    Kind("no-mu", "number", "no OFF windows to estimate μ from",
         "no OFF windows to estimate mu from; no electrostatic force",
         "Record OFF phases (or whole-OFF trials) for the subject.", "subject"),
    Kind("no-force", "number", "no electrostatic force",
         "no electrostatic force: {error}",
         "Put right what the message names and analyse the study again.", "subject",
         stands_for=("no-on-window", "no-force-anywhere")),
    Kind("no-on-window", "number", "no ON window in the study",
         "no electrostatic force: no trial has an ON window ({windows} OFF windows: the "
         "trials' condition is off, or the amplifier's status never said ON); evtribo report "
         "shows each subject's μ",
         "Check the sidecars' condition and the rig's excitation signals (evtribo plot trial "
         "shows ON and OFF).", "study"),
    Kind("no-force-anywhere", "number", "no subject with ON and OFF windows",
         "no electrostatic force: no subject has both ON and OFF windows with a known "
         "amplitude; evtribo report shows each subject's μ",
         "Record ON and OFF phases for each subject, with the amplitude in the sidecars or "
         "the excitation signals.", "study"),
    Kind("other-off", "number", "ON windows compared with other trials' OFF windows",
         "trial {trial} alternates but has no OFF window; using the subject's OFF windows",
         "Make each alternating trial's OFF phases long enough for steady sliding.",
         "drive"),
    Kind("whole-off", "information", "no whole-OFF trial",
         "no whole-OFF trial; trial {trial} is compared with the OFF phases of alternating "
         "trials", "Nothing to do; record a whole-OFF trial to compare ON-only trials with.",
         "drive"),
    Kind("few-windows", "interval", "fewer than 5 ON or OFF windows",
         "only {on} ON and {off} OFF windows (fewer than {min_windows}); the interval is "
         "calibrated for small counts but rests on few windows",
         "Record longer or more trials at this amplitude for a narrower interval.", "cell"),
    Kind("power-law-near-zero", "number",
         "cells left out of the power law (F_el within its error of zero)",
         "left out of the power law: F_el's interval reaches zero or below ({low_mN:.3g} to "
         "{high_mN:.3g} mN), so the data do not determine its logarithm",
         "Nothing to do if the force is small there; record longer at this amplitude to tell "
         "it from zero.", "cell"),
    Kind("no-power-law", "number", "no power law", "no power law: {error}",
         "Record the drive at two amplitudes or more (with a force at each) for its power "
         "law.", "drive"),
)

_LAW = (
    Kind("law-untold", "number", "friction law not measured (m = 1)",
         "the OFF windows' normal forces span too little to tell how the friction grows "
         "with the load ({found}; F_t = c W^m, a finger pad's m is 0.67-0.9): "
         "electrostatic_force_N is Amontons' (m = 1), and electrostatic_force_m075_N gives "
         "F_el at m = {sensitivity:g}, higher by about a third; OFF phases at two or three "
         "target presses measure m (docs/analysis.md, \"The friction law\")",
         "Record OFF phases at two or three target presses to measure the friction law's "
         "exponent m.", "subject"),
    Kind("drift-followed", "information", "friction changed within trials, followed",
         _DRIFT + "; each ON window was compared with its trial's OFF friction at its own "
         "time (mu_change_per_10s in trials.csv)",
         "Nothing to do; alternate ON and OFF within each trial, as here.", "subject"),
    Kind("drift-unseen", "number", "friction changed within ON-only trials",
         _DRIFT + "; trials {on_trials} are ON throughout and were compared with other "
         "trials' OFF windows, so such a change goes into their electrostatic force unseen: "
         "alternate ON and OFF within each trial",
         "Alternate ON and OFF within each trial.", "subject"),
    Kind("pace", "information", "friction follows the strokes' pace",
         "the friction follows the strokes' pace (faster strokes, other friction){slower}; "
         "each ON window was compared with the OFF friction at its own stroke's pace "
         "(docs/analysis.md, \"Speed and direction\")",
         "Nothing to do; strokes at an even pace make the comparison simpler.", "subject"),
    Kind("mu-scatter", "interval", "friction scatters between strokes",
         "the OFF windows' friction coefficient scatters by {scatter_pct:.0f} % between "
         "strokes (speed, posture) beyond what the strokes' pace explains; the intervals "
         "include it: strokes of an even pace and length narrow them",
         "Slide at an even pace and length to narrow the intervals.", "subject"),
    Kind("long-phases", "interval", "phases too long to tell a drift",
         "in trials {trials} the ON and OFF phases are too long to tell a drift of the "
         "friction (a moistening finger) from the voltage's effect: fitting the drift widens "
         "F_el's interval up to {widening:.1f}-fold, and a drift the data do not show clearly "
         "goes into F_el; with trials of {trial_s:.0f} s, phases of {phase_s:g} s or shorter "
         "keep the two apart",
         "Make the ON and OFF phases as short as the message says.", "subject"),
)

_PLAUSIBLE = (
    Kind("mu-implausible", "number", "friction coefficient outside what fingers give",
         "friction coefficient {mu:.2f}, outside what fingers give on glass "
         "({mu_low:g}-{mu_high:g}): the roles normal_force and tangential_force in "
         "study.toml may be swapped, or a cell's scale in the DBC wrong; the electrostatic "
         "forces rest on it",
         "Check the roles in study.toml and the load cells' scales in the DBC.", "subject"),
    Kind("negative-force", "number", "electrostatic force below zero beyond its interval",
         "the electrostatic force is below zero beyond chance at {amplitudes} (Holm's test "
         "over the study's {cells} cells at {alpha_pct:g} %: the voltage lowered the "
         "friction): the roles in study.toml may be swapped, the excitation's ON/OFF signal "
         "inverted, or a sidecar's condition wrong",
         "Check the roles in study.toml, the excitation's ON/OFF signal and the sidecars' "
         "conditions.", "subject"),
    Kind("crosstalk-normal", "number", "the normal cell reads part of the tangential force",
         "the normal cell reads {share_pct:+.1f} % (+/- {share_se_pct:.1f}, over {trials} "
         "trials) of the tangential force: its reading jumps with each reversal of the "
         "strokes; cross-talk, or a finger pressing harder one way. The electrostatic force "
         "weighs both directions alike and is not biased by it, but the normal forces "
         "reported are: give [rig.calibration] matrix = [[1.0, {matrix_b:.4f}], [0.0, 1.0]] "
         "in study.toml, or measure the whole matrix with evtribo calibrate",
         "Give [rig.calibration] matrix in study.toml as the message says, or measure it "
         "with evtribo calibrate.", "study"),
    Kind("crosstalk-tangential", "information",
         "the tangential reading follows the normal force",
         "the tangential reading follows the normal force by {share_pct:+.1f} % of it in "
         "both sliding directions ({trials} trials): cross-talk from the normal axis, or "
         "friction that differs between the directions; the electrostatic force compares "
         "each direction with its own friction. evtribo calibrate on a recording of the "
         "finger pressing without sliding tells the two apart",
         "Record the finger pressing without sliding and run evtribo calibrate to tell the "
         "two apart.", "study"),
    Kind("same-log", "information", "the same recording under two names",
         "its log {log} is identical to {same}'s ({same_log}, sha256 {sha256}...): the same "
         "recording under two names, counted once, as {same}{differ}",
         "Remove the copy from the study, or replace it with the recording it should be.",
         "trial"),
)

#: The study's kinds, in the order the documentation lists them.
STUDY_KINDS: tuple[Kind, ...] = (*_FORCE, *_LAW, *_PLAUSIBLE)
