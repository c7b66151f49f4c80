"""What the analysis says of a clean study: each note that claims an effect (a moistening
finger, friction following the strokes' pace, cross-talk, a force below zero, phases too
long, ...) is raised in no more than 5 % of clean simulated studies.

A clean study: a real rig (offsets, drift, hum, a tare stretch) and a person's strokes
(irregular, resting, lifting, a wandering press), a finger pad's friction law (m drawn in
0.67-0.9), and none of the effects the notes name: no moisture, no speed or direction
dependence, no cross-talk. The studies are small (2 subjects x 3 amplitudes, 12-s
trials), as cheap as they can be while every note can still fire: each has six
alternating trials, enough for the study-level cross-talk notes and each trial's drift.
"""

from __future__ import annotations

import collections
import re

import pytest

from _realistic import run_study
from evtribo.acquisition.simulator.realism import real_finger

#: Studies simulated (at most 5 % of them, one, may raise a note).
STUDIES = 20
#: The notes that claim an effect of the finger or the rig, by how they begin.
EFFECTS = {
    "moisture": "the friction coefficient changed within",
    "pace": "the friction follows the strokes' pace",
    "cross-talk, normal": "the normal cell reads",
    "cross-talk, tangential": "the tangential reading follows the normal force",
    "below zero": "the electrostatic force is below zero",
    "long phases": "the ON and OFF phases are too long",
}

def _clean_finger(subject):
    return real_finger(subject, seed=int(subject.name[1:]), moisture=False, speed=False,
                       direction=False, trials=False, load=True)


def kind(text: str) -> str:
    """A note's kind: its words after the subject, cell or trial it names, digits as #."""
    body = re.sub(r"^(?:[\w-]+/[\w-]+|[\w-]+ \([^)]*\)(?: at [\d.]+ V)?|[\w-]+): ", "", text,
                  count=1)
    body = re.sub(r"[-+]?\d[\d.,]*", "#", body)
    return " ".join(re.split(r"[;(:]", body)[0].split()[:7])


@pytest.mark.slow
def test_a_clean_study_raises_no_note_of_an_effect_in_more_than_5_percent_of_studies():
    raised: collections.Counter[str] = collections.Counter()
    kinds: set[str] = set()
    for seed in range(STUDIES):
        run = run_study(1000 + seed, n_subjects=2, amplitudes=(80.0, 110.0, 140.0),
                        duration_s=12.0, subject_changes=_clean_finger, n_boot=200)
        assert len(run.electrostatic) == 6
        kinds |= {kind(w) for w in run.study_warnings}
        raised.update({name for name, start in EFFECTS.items()
                       if any(start in w for w in run.study_warnings)})
    assert kinds  # the notes of the design (few windows, the law untold) are raised
    assert all(n <= 0.05 * STUDIES for n in raised.values()), raised
