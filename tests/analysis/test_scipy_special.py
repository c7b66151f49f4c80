"""The quantiles of the analysis, the fit and the population come from scipy.special
(importing scipy.stats costs 0.3-0.5 s): they are the numbers scipy.stats gives, bit for bit,
over the range they are asked for. ``compare`` starts without scipy.stats, the CAN
libraries and the trials' analysis (imported when a trial's check needs them)."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from scipy import special, stats

from evtribo.analysis.friction.estimate import small_sample_scale

probabilities = st.floats(min_value=0.5, max_value=1 - 1e-9)
dofs = st.floats(min_value=0.5, max_value=1e6)


@given(q=probabilities, dof=dofs)
def test_student_t_quantile(q, dof):
    assert special.stdtrit(dof, q) == stats.t.ppf(q, dof)


@given(q=probabilities)
def test_normal_quantile(q):
    assert special.ndtri(q) == stats.norm.ppf(q)


@given(p=st.floats(min_value=1e-12, max_value=0.5), k=st.integers(min_value=1, max_value=10_000))
def test_chi2_upper_quantile(p, k):
    assert special.chdtri(k, p) == stats.chi2.isf(p, k)


@given(q=st.floats(min_value=0.5, max_value=1 - 1e-9),
       dof=st.floats(min_value=0.01, max_value=1e6))
def test_chi2_quantile_of_any_degrees_of_freedom(q, dof):
    # the population's variance intervals (Satterthwaite's degrees of freedom, not whole)
    for p in (q, 1.0 - q):
        assert 2.0 * special.gammaincinv(dof / 2.0, p) == stats.chi2.ppf(p, dof)


@given(z=st.floats(min_value=-40.0, max_value=40.0))
def test_normal_upper_tail(z):
    assert special.ndtr(-z) == stats.norm.sf(z)


@given(v=st.lists(st.floats(min_value=1e-6, max_value=1.0), min_size=1, max_size=6),
       n=st.lists(st.integers(min_value=2, max_value=40), min_size=6, max_size=6),
       confidence=st.sampled_from([0.9, 0.95, 0.99]))
def test_the_small_sample_scale_is_the_one_scipy_stats_gives(v, n, confidence):
    counts = np.array(n[:len(v)], dtype=float)
    var = np.array(v)
    w = var * counts / (counts - 1.0)
    dof = float(np.sum(w) ** 2 / np.sum(w**2 / (counts - 1.0)))
    q = 1.0 - (1.0 - confidence) / 2.0
    expected = float(np.sqrt(np.sum(w) / np.sum(var))) * float(
        stats.t.ppf(q, dof) / stats.norm.ppf(q))
    assert small_sample_scale(var, counts, confidence) == (expected, dof)


def test_the_analysis_does_not_import_scipy_stats():
    import subprocess
    import sys

    code = ("import sys, evtribo.cli.results.analyze, evtribo.results.pipeline; "
            "print(sorted(m for m in ('scipy.stats', 'scipy.signal') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"
    np.testing.assert_equal(special.ndtri(0.975), stats.norm.ppf(0.975))


def test_compare_starts_without_scipy_stats_the_can_libraries_or_the_analysis():
    import subprocess
    import sys

    heavy = ("scipy.stats", "cantools", "can", "asammdf", "evtribo.analysis.trial",
             "evtribo.results.trial_view", "evtribo.canlog.decode")
    code = ("import sys, evtribo.cli.results.compare, evtribo.report.compare; "
            f"print(sorted(m for m in {heavy!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def test_a_sine_trials_hum_is_removed_by_scipy_signal(tmp_path):
    """A sine drive's trial with mains hum has its spectrum taken and its hum notched out by
    scipy.signal, which is imported only where a hum is looked for (not by importing the
    analysis: see the test above)."""
    import subprocess
    import sys

    from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study

    study = tmp_path / "study"
    simulate_study(study, default_subjects(1), amplitudes=(140.0,),
                   config=TrialConfig(duration_s=20.0), sine_trial=True, realistic=True)
    code = ("import logging, sys\n"
            "from evtribo.results.pipeline import compute_study\n"
            "removed = []\n"
            "class Keep(logging.Handler):\n"
            "    def emit(self, record):\n"
            "        if 'hum' in record.getMessage() and 'removed' in record.getMessage():\n"
            "            removed.append(record.getMessage())\n"
            "logging.getLogger('evtribo').addHandler(Keep())\n"
            "logging.getLogger('evtribo').setLevel(logging.INFO)\n"
            f"res = compute_study({str(study)!r}, jobs=1, cache_dir={str(tmp_path / 'c')!r})\n"
            "print(sorted(res.trials.waveform.unique()), bool(removed),"
            " 'scipy.signal' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip().splitlines()[-1] == "['sine', 'square'] True True"
