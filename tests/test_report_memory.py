"""The report's and the result's long-trial reductions taken in blocks (issue 37): the same values
as the whole-array expressions they replace, without temporaries as long as the trial."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from limbstiff.report import common, quality
from limbstiff.result import StiffnessResult
from limbstiff.signals import welch_spectrum


@pytest.mark.parametrize("n, fs", [(257, 100.0), (1000, 500.0), (60001, 1000.0), (123457, 2000.0)])
def test_the_spectrum_in_blocks_is_welchs(monkeypatch, n, fs):
    monkeypatch.setattr(quality, "SPECTRUM_SEGMENTS", 3)
    monkeypatch.setattr(quality, "SPECTRUM_BLOCK", 1000)
    rng = np.random.default_rng(n)
    x = np.cumsum(rng.standard_normal(n)) + 0.01 * np.arange(n) + 5.0
    freq, psd = welch_spectrum(x, fs)
    got_freq, asd = quality.spectrum(x, fs)
    assert np.array_equal(freq, got_freq)
    np.testing.assert_allclose(asd, np.sqrt(psd), rtol=1e-9)


def test_envelopes_with_a_mask_are_those_of_the_masked_copy(monkeypatch):
    monkeypatch.setattr(common, "BIN_BLOCK", 777)
    rng = np.random.default_rng(1)
    n = 50_000
    t, y, lo, hi = np.arange(n) / 1e3, rng.standard_normal(n), rng.standard_normal(n) - 2, rng.standard_normal(n) + 2
    use = rng.uniform(size=n) < 0.7
    use[10_000:20_000] = False                                        # whole bins of NaN
    blank = [np.where(use, v, np.nan) for v in (y, lo, hi)]
    for got, want in ((common.envelope(t, y, where=use), common.envelope(t, blank[0])),
                      (common.envelope_band(t, lo, hi, where=use), common.envelope_band(t, blank[1], blank[2])),
                      (common.envelope(t[:900], y[:900], where=use[:900]), common.envelope(t[:900], blank[0][:900]))):
        for a, b in zip(got, want):
            np.testing.assert_array_equal(a, b)


def _fake_result(n: int, seed: int):
    rng = np.random.default_rng(seed)
    reference = np.where(rng.uniform(size=n) < 0.01, 0.0, 50 + rng.standard_normal(n))
    stiffness = reference * (1 + 0.01 * rng.standard_normal(n))
    return SimpleNamespace(trial=SimpleNamespace(time=10.0 + np.arange(n) / 1000.0), reference=reference,
                           observable=rng.uniform(size=n) < 0.8, stiffness=stiffness,
                           stiffness_lo=stiffness - rng.uniform(0, 1, n), stiffness_hi=stiffness + rng.uniform(0, 1, n),
                           trial_level=None)


def test_reference_error_and_median_are_the_whole_array_ones():
    r = _fake_result(700_001, 2)
    use = r.observable & (r.trial.time - r.trial.time[0] >= 2.0) & (r.reference != 0)
    got_use = StiffnessResult.reference_samples(r, skip=2.0)
    np.testing.assert_array_equal(got_use, use)
    r.reference_samples = lambda skip: StiffnessResult.reference_samples(r, skip=skip)
    rel = np.abs(r.stiffness[use] - r.reference[use]) / np.abs(r.reference[use])
    inside = (r.stiffness_lo[use] <= r.reference[use]) & (r.reference[use] <= r.stiffness_hi[use])
    assert StiffnessResult.reference_error(r, skip=2.0) == {
        "median": float(np.median(rel)), "p90": float(np.percentile(rel, 90)),
        "coverage": float(np.mean(inside)), "n": int(use.sum())}
    median, low, high = StiffnessResult.informed_stiffness(r)
    obs = r.observable
    assert (median.median, median.lo, median.hi, low, high) == (
        float(np.median(r.stiffness[obs])), float(np.median(r.stiffness_lo[obs])),
        float(np.median(r.stiffness_hi[obs])), float(np.min(r.stiffness[obs])), float(np.max(r.stiffness[obs])))
