"""Protocol files (spec §7): checked with file, line and key, and the trials they plan."""

from __future__ import annotations

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


def test_the_example_protocols_are_in_the_package_as_they_are_here():
    """The README's examples reach an installed evtribo (the wheel's package data; the
    sdist has acquisition/ too: tests/test_release.py), byte for byte."""
    from evtribo.acquisition.protocol import example_protocols

    shipped = example_protocols()
    assert sorted(p.name for p in shipped) == ["frequency-sweep.toml", "meyer2013.toml"]
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
