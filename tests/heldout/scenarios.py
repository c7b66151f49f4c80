"""Named scenarios: the clean lab study and one hostile change (or a few) at a time."""

from __future__ import annotations

from dataclasses import replace

from .config import (
    Cells,
    Drive,
    Electrostatic,
    Friction,
    Logger,
    Press,
    Strokes,
    StudyConfig,
)

CLEAN = StudyConfig()

WANDER = Press(mode="walk")
IRREGULAR = Strokes(duration_s=(0.6, 2.4), speed_wobble=0.15, dwell_s=(0.0, 0.25))


def _powerlaw(m: float, press: Press | None = None) -> StudyConfig:
    name = f"m{round(m * 100):03d}" + ("-wander" if press is not None else "")
    return replace(CLEAN, name=name, friction=Friction(m=m), press=press or Press())


def _scenarios() -> dict[str, StudyConfig]:
    out = {"clean": CLEAN}
    for m in (0.67, 0.75, 0.9):
        for press in (None, WANDER):
            cfg = _powerlaw(m, press)
            out[cfg.name] = cfg
    out["wander"] = replace(CLEAN, name="wander", press=WANDER)
    out["sweep"] = replace(CLEAN, name="sweep", press=Press(mode="sweep"))
    out["speed"] = replace(CLEAN, name="speed", strokes=IRREGULAR,
                           friction=Friction(speed_exponent=0.15, direction_asymmetry=0.06))
    out["moisture"] = replace(CLEAN, name="moisture", trial_s=24.0,
                              friction=Friction(moisture_rise=(0.2, 0.6),
                                                moisture_tau_s=(4.0, 12.0)))
    for phase in (5.0, 10.0):
        name = f"long-phases-{phase:.0f}s"
        out[name] = replace(CLEAN, name=name, trial_s=1.5 + 4 * phase + 2.0,
                            drive=Drive(phase_s=phase),
                            friction=Friction(trend_per_10s=0.2))
    out["noisy-population"] = replace(
        CLEAN, name="noisy-population", subjects=8, trial_s=20.0,
        electrostatic=Electrostatic(model="power", n_sd=0.15, weak_share=0.25),
        friction=Friction(stroke_scatter=0.02, trial_spread=0.08))
    out["short-scatter"] = replace(CLEAN, name="short-scatter", trial_s=12.0,
                                   friction=Friction(stroke_scatter=0.04))
    out["targets-m075"] = replace(CLEAN, name="targets-m075", trial_s=20.0,
                                  friction=Friction(m=0.75), press=Press(mode="targets"))
    out["sidecar"] = replace(CLEAN, name="sidecar", drive=Drive(signal="sidecar"),
                             trial_s=10.0)
    out["rig-flaws"] = replace(
        CLEAN, name="rig-flaws",
        cells=Cells(offset_N=0.05, drift_N=0.01, hum_N=0.01, crosstalk=0.03, creep=0.02),
        logger=Logger(rates_Hz=(500.0, 800.0), jitter_s=(0.0005, 0.001), batch_s=0.004,
                      clock_ppm=200.0, drop_rate=0.002),
        strokes=Strokes(lifts_per_min=4.0))
    out["sine"] = replace(CLEAN, name="sine", drive=Drive(waveform="sine", frequency_Hz=10.0))
    out["everything"] = replace(
        out["rig-flaws"], name="everything", subjects=6, trial_s=20.0, strokes=IRREGULAR,
        press=WANDER,
        electrostatic=Electrostatic(model="power", n_sd=0.15, weak_share=0.2),
        friction=Friction(m=0.8, speed_exponent=0.15, direction_asymmetry=0.06,
                          moisture_rise=(0.1, 0.4), stroke_scatter=0.02, trial_spread=0.08))
    return out


SCENARIOS: dict[str, StudyConfig] = _scenarios()
