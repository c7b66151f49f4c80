"""Protocol files (spec §7): checked with file, line and key, and the trials they plan."""

from __future__ import annotations

import io
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.acquisition.protocol import plan_trials, read_protocol
from evtribo.errors import ConfigError

PROTOCOLS = Path(__file__).parents[2] / "acquisition" / "protocols"


def test_example_protocols_plan_what_they_say():
    meyer = read_protocol(PROTOCOLS / "meyer2013.toml")
    plan = plan_trials(meyer)
    assert len(plan) == 10
    assert Counter(p.amplitude_V for p in plan) == dict.fromkeys((60, 80, 100, 120, 140), 2)
    assert {(p.waveform, p.frequency_Hz, p.condition) for p in plan} == \
        {("square", 10000.0, "alternating")}
    sweep = plan_trials(read_protocol(PROTOCOLS / "frequency-sweep.toml"))
    assert len(sweep) == 13 and {p.amplitude_V for p in sweep} == {100.0}
    law = read_protocol(PROTOCOLS / "friction-law.toml")
    assert law.session.target_steps_N == (0.3, 0.6, 0.9) and law.session.step_s == 5.0
    assert len(plan_trials(law)) == 10
    assert type(law).from_dict(law.to_dict(), law.source) == law  # as session.json keeps it


@given(elapsed=st.floats(0, 60), steps=st.lists(st.floats(0.1, 2.0), min_size=1, max_size=4),
       step_s=st.floats(0.5, 10))
@settings(max_examples=60, deadline=None)
def test_the_monitors_target_steps_through_the_presses_after_the_tare(elapsed, steps, step_s):
    from evtribo.acquisition.live.monitor import Monitor
    from evtribo.acquisition.rigfile import default_rig_path, load_rig_toml

    mon = Monitor(load_rig_toml(default_rig_path()), io.StringIO(), target=0.5, tare_s=1.5,
                  steps=tuple(steps), step_s=step_s)
    target = mon.target_at(elapsed)
    if elapsed < 1.5:
        assert target == 0.5
    else:  # the step of that time, each held step_s, in turn
        k = int((elapsed - 1.5) // step_s)
        assert target == steps[k % len(steps)]
        assert mon.target_at(1.5 + (k + 0.5) * step_s) == target
    assert Monitor(mon.rig, io.StringIO(), target=0.5).target_at(elapsed) == 0.5


def test_the_example_protocols_are_in_the_package_as_they_are_here():
    """The README's examples reach an installed evtribo (the wheel's package data; the
    sdist has acquisition/ too: tests/test_release.py), byte for byte."""
    from evtribo.acquisition.protocol import example_protocols

    shipped = example_protocols()
    assert sorted(p.name for p in shipped) == ["frequency-sweep.toml", "friction-law.toml",
                                               "meyer2013.toml"]
    for path in shipped:
        assert path.read_bytes() == (PROTOCOLS / path.name).read_bytes(), path.name


@settings(max_examples=30, deadline=None)
@given(amps=st.lists(st.integers(1, 300), min_size=1, max_size=5),
       freqs=st.lists(st.integers(1, 20000), min_size=1, max_size=4),
       shape=st.tuples(st.integers(1, 3), st.integers(0, 2**31 - 1), st.booleans()))
def test_plan_is_every_combination_repeated_and_seeded(tmp_path_factory, amps, freqs, shape):
    reps, seed, randomize = shape
    path = tmp_path_factory.mktemp("p") / "p.toml"
    path.write_text(f"[session]\nrepetitions = {reps}\nrandomize = {str(randomize).lower()}\n"
                    f"seed = {seed}\n[[trial]]\nwaveform = \"sine\"\n"
                    f"frequency_Hz = {freqs}\namplitude_V = {amps}\n")
    protocol = read_protocol(path)
    plan = plan_trials(protocol)
    expected = Counter((float(f), float(a)) for f in freqs for a in amps)
    got = Counter((p.frequency_Hz, p.amplitude_V) for p in plan)
    assert got == Counter({k: v * reps for k, v in expected.items()})
    assert plan == plan_trials(protocol)  # the seed fixes the order
    if not randomize:
        assert [(p.frequency_Hz, p.amplitude_V) for p in plan[: len(freqs) * len(amps)]] == \
            [(float(f), float(a)) for f in freqs for a in amps]


@pytest.mark.parametrize(("text", "key", "line", "message"), [
    ("[session]\ntrial_s = 20\nrepetiton = 2\n[[trial]]\n", "session.repetiton", 3,
     "did you mean 'repetitions'"),
    ("[session]\ntrial_s = -1\n[[trial]]\n", "session.trial_s", 2, "> 0"),
    ("[[trial]]\nwaveform = \"sine\"\n[[trial]]\namplitude = 3\n", "trial[2].amplitude", 4,
     "did you mean 'amplitude_V'"),
    ("[[trial]]\nwaveform = \"saw\"\n", "trial[1].waveform", 2, "sine, square"),
    ("[[trial]]\namplitude_V = []\n", "trial[1].amplitude_V", 2, "no trial"),
    ("[session]\ntrial_s = 20\n", "trial", None, "no [[trial]]"),
    ("[session]\ntarget_steps_N = [0.3, -0.6]\n[[trial]]\n", "session.target_steps_N", 2,
     "> 0"),
    ("[session]\ntarget_steps_N = 0.3\n[[trial]]\n", "session.target_steps_N", 2,
     "a list of numbers"),
])
def test_bad_protocols_name_file_line_and_key(tmp_path, text, key, line, message):
    path = tmp_path / "p.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        read_protocol(path)
    assert err.value.key == key and err.value.line == line
    assert message in str(err.value) and str(path) in str(err.value)


def test_missing_protocol_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        read_protocol(tmp_path / "nope.toml")


def test_a_protocol_kept_before_the_stepped_target_reads_back_with_its_defaults():
    from evtribo.acquisition.protocol import Protocol

    meyer = read_protocol(PROTOCOLS / "meyer2013.toml")
    kept = meyer.to_dict()
    for key in ("target_steps_N", "step_s"):  # what session.json held before these existed
        del kept["session"][key]
    assert Protocol.from_dict(kept).to_dict() == meyer.to_dict()
