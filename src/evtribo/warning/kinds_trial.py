"""The kinds of warning about one trial's analysis: a trial not analysed, the load cells'
roles and zeros, the excitation, the pieces of a trial and its windows."""

from __future__ import annotations

from evtribo.warning.kind import Kind

__all__ = ["TRIAL_KINDS"]

_OUTCOME = (
    Kind("not-analysed", "number", "trials not analysed", "not analysed: {error}",
         "Put right what the message names and analyse the study again; the trial is in no "
         "result until then.", "trial"),
    Kind("more-warnings", "information", "more warnings of a trial, counted",
         "... and {more} more",
         "Analyse the study again with -vv to see every one of the trial's warnings as it is "
         "said.",
         "trial"),
    Kind("roles", "number", "the normal and tangential roles look swapped",
         "the normal and tangential roles look swapped: the signal named normal_force "
         "changes sign with the strokes ({normal_crossings:.2f} crossings/s, positive "
         "{normal_positive_pct:.0f} % of the time) while the one named tangential_force keeps "
         "its sign ({tangential_crossings:.2f} crossings/s, positive "
         "{tangential_positive_pct:.0f} %); check [rig] normal_force and tangential_force in "
         "study.toml (evtribo inspect LOG --dbc DBC shows how each signal behaves); every "
         "number of this trial assumes the roles as named",
         "Check [rig] normal_force and tangential_force in study.toml (evtribo inspect shows "
         "how each signal behaves) and analyse again.", "trial"),
    Kind("sidecar-signals", "information", "sidecar and excitation signals disagree",
         "the sidecar says {key} = {sidecar!r} but the excitation signals say {signals!r}; "
         "using the signals",
         "Correct the sidecar if the excitation signals are right (they are what was "
         "used).", "trial"),
)

_ZERO = (
    Kind("no-lift", "information", "no finger-lifted stretch where the sidecar says one",
         "the sidecar says the finger was lifted for the first {tare_s:g} s, but no "
         "finger-lifted stretch was found in the forces (was it kept on the screen?)",
         "Lift the finger off the screen for the tare stretch at the start of each trial.",
         "trial"),
    Kind("tangential-zero", "number", "the tangential cell's zero is unknown",
         "the tangential cell's zero is unknown: no finger-lifted stretch, no "
         "[rig.calibration] tangential_offset_N, and too few strokes in both directions for "
         "the friction loop; an offset adds to the friction one way and subtracts the other",
         "Record a tare stretch (evtribo acquire --tare-s), give [rig.calibration] "
         "tangential_offset_N, or slide both ways in each phase.", "trial"),
    Kind("directions-confounded", "number", "ON windows left out: slid the other way from "
         "the OFF windows, the zero unknown",
         "{left} of {on} ON windows are left out: the OFF windows all slid {way}, and with "
         "the tangential cell's zero unknown an ON window sliding the other way differs from "
         "them by twice the cell's offset besides the voltage's effect (the electrostatic "
         "force cannot be told from the offset); record a tare stretch (evtribo acquire "
         "--tare-s), give [rig.calibration] tangential_offset_N, or slide both ways in each "
         "phase",
         "Record a tare stretch (evtribo acquire --tare-s), give [rig.calibration] "
         "tangential_offset_N, or slide both ways in each phase.", "trial"),
    Kind("normal-zero", "number", "the normal cell's zero is unknown",
         "the normal cell's zero is unknown (no finger-lifted stretch and no "
         "[rig.calibration] normal_offset_N): an offset of 10 mN would change F_el by "
         "{change_pct:.1f} % (offset / F_n, at this trial's {normal_N:.2f} N); record a tare "
         "stretch (evtribo acquire --tare-s) or give [rig.calibration] normal_offset_N",
         "Record a tare stretch (evtribo acquire --tare-s) or give [rig.calibration] "
         "normal_offset_N.", "trial"),
    Kind("offset", "information", "zero offsets removed",
         "the {cell} cell's zero offset was {offset_mN:+.1f} mN, {share_pct:.0f} % of the "
         "{cell} force measured ({force_N:.3f} N); removed, but tare the load cells before "
         "recording",
         "Tare the load cells before recording.", "trial"),
    Kind("zero-drift", "information", "zeros that drifted, followed",
         "the {cell} cell's zero drifted by {drift_mN:+.1f} mN between the finger-lifted "
         "stretches at {first_s:.1f} s and {last_s:.1f} s (noise {noise_mN:.2f} mN); "
         "interpolated between them",
         "Nothing to do; let the load cells warm up before recording if their zeros drift "
         "much.", "trial"),
    Kind("sign-flipped", "information", "negative normal force, sign flipped",
         "the normal force is negative: its sign is flipped (compression counted positive)",
         "Nothing to do; or give the normal cell's scale a negative factor in the DBC.",
         "trial"),
)

_EXCITATION = (
    Kind("amplitude-unknown", "number", "amplitude of the ON windows unknown",
         "the amplitude of the ON windows is unknown (no excitation amplitude signal, no "
         "'amplitude_V' in the sidecar)",
         "Give the trial's amplitude_V in its sidecar, or an excitation amplitude signal in "
         "the rig file.", "trial"),
    Kind("modulation", "information", "friction modulation not measured",
         "friction modulation at 2 x {frequency_Hz:g} Hz is beyond what the load cells' "
         "{rate_Hz:.0f} Hz sampling can resolve",
         "Nothing to do for F_el; sample the load cells faster to measure the modulation.",
         "trial",
         stands_for=("modulation-none",)),
    Kind("modulation-none", "information", "no friction modulation stands out",
         "no oscillation of the friction stands out in the ON windows' spectrum (too short, "
         "or too weak against the noise and the pressing force's wander): no "
         "friction_modulation_Hz",
         "Nothing to do for F_el; longer ON phases at a steady press show the modulation.",
         "trial"),
)

_PIECES = (
    Kind("pause", "information", "the load cells silent for a while",
         "no frame of the load cells for {gap_s:duration} ({gap_s:.3f} s) after "
         "{at_s:.3f} s: a jump of the log's clock or a pause of the recording",
         "Nothing to do; the trial is analysed in its continuous pieces.", "trial"),
    Kind("pieces", "information", "trials analysed in pieces",
         "analysed in {pieces} continuous pieces",
         "Nothing to do; each piece is analysed on its own.", "trial",
         stands_for=("pause",)),
    Kind("piece-left", "interval", "pieces of a trial not analysed",
         "the piece from {start_s:.3f} s to {end_s:.3f} s is not analysed: {error}",
         "Nothing to do if the piece is short; the rest of the trial is analysed.",
         "trial"),
    Kind("no-window", "interval", "trials without a steady-sliding window",
         "no steady-sliding window found",
         "Slide at a steady pace and press for a few strokes in each phase (evtribo plot "
         "trial shows what the analysis saw).", "trial"),
)

#: A trial's kinds, in the order the documentation lists them.
TRIAL_KINDS: tuple[Kind, ...] = (*_OUTCOME, *_ZERO, *_EXCITATION, *_PIECES)
