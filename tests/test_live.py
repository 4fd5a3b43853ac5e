"""The live (causal) estimate without a stream: the chain against the model written once, chunking,
the session's gaps and identification failures, the live checks' error rates, the growing table."""

import pickle
from concurrent.futures import Future

import numpy as np
import pytest
from scipy import signal

from limbstiff.errors import TrialError
from limbstiff.files.recording import GrowingTable
from limbstiff.live import kernel
from limbstiff.signals import CENTRAL_FIRST, CENTRAL_SECOND
from limbstiff.checks.verdict import CAUTION, OK, Verdict
from limbstiff.live.checks import HINDSIGHT_Z, TRACKING_Z, VERDICT_NAMES, hindsight, live_checks
from limbstiff.live.estimator import LiveEstimator, LiveModel
from limbstiff.live.session import Immediately, LiveSession, identification_due
from limbstiff.live.status import status_line
from limbstiff.statespace import kernels
from limbstiff.statespace.noise import NoiseLevels
from limbstiff.statespace.smoother import at_steps

from .conftest import multisine_trial
from .support.independent_trials import make_trial, suite

FS = 500.0


def _model(**changes):
    base = dict(fs=FS, corner_hz=20.0, motion_hz=2.0,
                noise=NoiseLevels(measurement=1e-4, torque_walk=1e-3, stiffness_walk=2.0, coupled_walk=0.5),
                inertia=0.06, damping=0.45, covariance=np.array([[1e-6, 2e-7], [2e-7, 1e-4]]),
                initial_cov=(1.0, 400.0), typical_variance=None)
    base.update(changes)
    return LiveModel(**base)


def _expected(model, y, f):
    """The chain written out with scipy and the offline filter (kernels.kalman_filter): a second,
    independent statement of what the live kernel computes."""
    sos = model.sos
    zi = signal.sosfilt_zi(sos)
    yf = signal.sosfilt(sos, y, zi=zi * y[0])[0]
    ff = signal.sosfilt(sos, f, zi=zi * f[0])[0]
    newest = np.arange(kernel.STENCIL - 1, len(y), model.decimation)     # the sample that completes each step
    centre = newest - 4
    window = np.lib.stride_tricks.sliding_window_view(yf, kernel.STENCIL)[centre - 4]
    v = window @ CENTRAL_FIRST * FS          # the offline chain's stencils (limbstiff.signals)
    a = window @ CENTRAL_SECOND * FS ** 2
    z = ff[centre] - model.inertia * a - model.damping * v
    yc = yf[centre]
    g = np.array([yc[i] - yc[max(0, i - model.window + 1):i + 1].mean() for i in range(len(yc))])
    d = np.diff(yc, prepend=yc[0])
    r, qs, qk, qc = model.noise.per_step(model.decimation / FS)
    mean, cov, _ = kernels.kalman_filter(d, g, z, np.ones(len(z), dtype=bool), r, qs, qk, qc, float(z[0]), 0.0,
                                         model.initial_cov[0], 0.0, model.initial_cov[1], False)
    return newest, at_steps(mean[:, 1]), at_steps(cov[:, 2]), z


def test_the_chain_is_the_offline_filter_on_causally_filtered_signals():
    trial = multisine_trial(duration=6.0, fs=FS)
    model = _model()
    out = LiveEstimator(model).push(trial.angle, trial.torque)
    newest, stiffness, variance, z = _expected(model, trial.angle, trial.torque)
    # the same arithmetic in another order (three channels combined after the filter): rounding only
    np.testing.assert_allclose(out.stiffness[newest], stiffness, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(out.rows[newest, 4], variance, rtol=1e-9)
    np.testing.assert_allclose(out.measured[newest], z, rtol=1e-9, atol=1e-12)
    assert np.all(np.isnan(out.stiffness[:newest[0]]))
    # held between steps: the value of the last step
    assert out.stiffness[newest[3] + 1] == out.stiffness[newest[3]]
    # the band carries m and b's covariance through the courses of ÿ and ẏ: wider than the state's own
    half = 0.5 * (out.hi - out.lo)[newest]
    assert np.all(half >= 1.6448 * np.sqrt(variance) * (1 - 1e-12))


def test_the_live_step_is_the_offline_filter_to_the_bit():
    """The chain's model step is the offline filter's (kernels.step): with m = b = 0 its z is the
    torque channel itself, so on the chain's own steps (z, y and the deflection it outputs) the
    innovations, their variance and the filtered stiffness are the offline pass's, bit for bit."""
    trial = multisine_trial(duration=4.0, fs=FS)
    model = _model(inertia=0.0, damping=0.0)
    rows = LiveEstimator(model).push(trial.angle, trial.torque).rows
    at = np.flatnonzero(np.isfinite(rows[:, 5]))
    z, y, g = rows[at, 7], rows[at, 8], rows[at, 9]
    args = (np.diff(y, prepend=y[0]), g, z, *model.noise.per_step(model.decimation / FS), float(z[0]), 0.0,
            model.initial_cov[0], 0.0, model.initial_cov[1])
    e, var = kernels.kalman_innovations(*args)
    np.testing.assert_array_equal(rows[at, 5], e)
    np.testing.assert_array_equal(rows[at, 6], var)
    mean, cov, _ = kernels.kalman_filter(*args[:3], np.ones(len(z), dtype=bool), *args[3:], False)
    np.testing.assert_array_equal(rows[at, 0], at_steps(mean[:, 1]))
    np.testing.assert_array_equal(rows[at, 4], at_steps(cov[:, 2]))


def test_chunks_and_a_pickled_handover_give_the_same_estimate_to_the_bit():
    trial = multisine_trial(duration=5.0, fs=FS)
    model = _model(memory_s=0.5, typical_variance=0.01)
    whole = LiveEstimator(model).push(trial.angle, trial.torque).rows
    for size in (1, 7, 250):
        est = LiveEstimator(model)
        rows = np.vstack([est.push(trial.angle[i:i + size], trial.torque[i:i + size]).rows
                          for i in range(0, len(trial.angle), size)])
        np.testing.assert_array_equal(rows, whole)
    est = LiveEstimator(model)
    est.push(trial.angle[:1000], trial.torque[:1000])
    moved = pickle.loads(pickle.dumps(est))         # what a worker process hands over
    np.testing.assert_array_equal(moved.push(trial.angle[1000:], trial.torque[1000:]).rows, whole[1000:])


def test_retuning_m_and_b_keeps_the_chain_and_changes_only_the_combination():
    trial = multisine_trial(duration=4.0, fs=FS)
    model = _model()
    est = LiveEstimator(model)
    est.push(trial.angle[:800], trial.torque[:800])
    import dataclasses
    est.retuned(dataclasses.replace(model, inertia=0.07))
    with pytest.raises(ValueError, match="keeps the chain"):
        est.retuned(dataclasses.replace(model, corner_hz=10.0))
    expected = LiveEstimator(dataclasses.replace(model, inertia=0.07)).push(trial.angle, trial.torque)
    np.testing.assert_allclose(est.push(trial.angle[800:], trial.torque[800:]).stiffness,
                               expected.stiffness[800:], rtol=1e-9)


def test_identification_schedule():
    due = [identification_due(k, warmup_s=5.0) for k in range(6)]
    assert due == [5.0, 10.0, 20.0, 40.0, 100.0, 160.0]


@pytest.fixture(scope="module")
def ramp_trial():
    """The independent simulator's clean elbow whose stiffness ramps (not limbstiff's equations), 30 s."""
    spec = next(s for s in suite(7100) if s.name == "clean-ramp-elbow")
    data, _ = make_trial(spec)
    return (data.angle_rad.to_numpy(), data.torque_Nm.to_numpy(), data.stiffness_true_Nm_per_rad.to_numpy(), 1000.0)


def _replay(session, y, f, fs, *, times=None, chunk=10):
    t = np.arange(len(y)) / fs if times is None else times
    parts = [session.feed(t[i:i + chunk], y[i:i + chunk], f[i:i + chunk]) for i in range(0, len(y), chunk)]
    return np.vstack([p.values for p in parts]), parts


@pytest.mark.slow
def test_a_replayed_session_follows_the_independent_ramp(ramp_trial):
    y, f, truth, fs = ramp_trial
    session = LiveSession(fs, Immediately())
    values, _ = _replay(session, y, f, fs)
    assert np.all(np.isnan(values[:5000, 0])) and np.all(values[:5000, 4] == -1)   # warm-up: said so
    use = np.isfinite(values[:, 0])
    use[:5000] = False
    error = np.abs(values[use, 0] / truth[use] - 1)
    # the target (5 %): 1.9 % measured (30 s; cut to its first 22 s, the ramp weighs more: 3.2 %)
    assert np.median(error) < 0.05
    assert [d["at_samples"] for d in session.events.identifications] == [5000, 10000, 20000]
    assert session.events.refits >= 8
    # every estimator that took over (an identification, a noise refit) saw each sample once: run
    # over the record it was given, then caught up, then fed (a chunk fed twice was a bug)
    assert session.estimator.istate[kernel.SEEN] == session.record.total == len(y)
    assert session.events.dropped_samples == 0 and session.events.breaks == []


@pytest.mark.slow
def test_dropped_samples_are_bridged_and_a_long_gap_restarts(ramp_trial):
    y, f, truth, fs = ramp_trial
    n = 20000
    t = np.arange(n) / fs
    keep = np.ones(n, dtype=bool)
    keep[8000:8020] = False            # 20 ms dropped: bridged
    keep[11000:13000] = False          # 2 s: a break (longer than a quarter motion period)
    session = LiveSession(fs, Immediately())
    values, parts = _replay(session, y[:n][keep], f[:n][keep], fs, times=t[keep])
    assert session.events.bridged_gaps == 1
    assert session.events.dropped_samples == 20 + 2000
    assert len(session.events.breaks) == 1
    before, after = session.events.breaks[0]
    assert before == pytest.approx(t[10999]) and after == pytest.approx(t[13000])
    assert sum(len(p.breaks) for p in parts) == 1
    after_break = np.flatnonzero(keep).searchsorted(13000)
    assert np.all(np.isnan(values[after_break:after_break + 8, 0]))     # the chain starts again
    assert np.all(values[after_break:after_break + 8, 4] == -1)         # and its checks
    # the chain converges again within its memory (two motion periods; this trial moves at 0.24 Hz)
    assert abs(values[-1, 0] / truth[n - 1] - 1) < 0.1


class _FailingFirst(Immediately):
    """An identifier whose first identification fails, as a record without motion would."""

    def __init__(self):
        super().__init__()
        self.calls = 0

    def submit(self, angle, torque, fs):
        self.calls += 1
        if self.calls == 1:
            done = Future()
            done.set_exception(TrialError("live", "no motion: the angle does not change"))
            return done
        return super().submit(angle, torque, fs)


def test_a_failed_identification_is_reported_and_the_next_one_taken(ramp_trial):
    y, f, _, fs = ramp_trial
    session = LiveSession(fs, _FailingFirst())
    values, _ = _replay(session, y[:11000], f[:11000], fs)
    first, second = session.events.identifications
    assert "no motion" in first["error"] and first["at_samples"] == 5000
    assert second["at_samples"] == 10000 and second["inertia"] > 0
    assert np.all(np.isnan(values[:10000, 0])) and np.isfinite(values[-1, 0])


def _window(rng, k, slope_in_half_widths):
    """A window of k steps whose innovations are white with S = 1, plus a stiffness missed by the
    estimate of ``slope_in_half_widths`` times the band's half-width (0.05)."""
    angle = np.cumsum(rng.normal(0, 0.01, k))
    d = np.diff(angle, prepend=angle[0])
    half = 0.05
    e = rng.normal(0, 1, k) + slope_in_half_widths * half * d
    stiffness = np.full(k, 1.0)
    return live_checks(stiffness, stiffness - half, stiffness + half, np.ones(k, bool), e, np.ones(k),
                       rng.normal(0, 5, k), angle)


def test_tracking_check_error_rates():
    rng = np.random.default_rng(38)
    # no missed stiffness: β/se is N(0, 1), so |z| > 3 in 0.27 % of windows (and |β| must pass the
    # half-width too); 400 windows: more than 3 false alarms would have probability < 2 % at 0.27 %
    quiet = [_window(rng, 300, 0.0) for _ in range(400)]
    assert sum("tracking" in c.failed for c in quiet) <= 3
    assert all(c.verdict == OK for c in quiet if "tracking" not in c.failed)
    # a stiffness missed by 4 half-widths with Σd² = 300·10⁻⁴: β = 0.2, se = 1/√0.03 ≈ 5.8 — not
    # significant, so not flagged: the check waits for evidence
    weak = [_window(rng, 300, 4.0) for _ in range(50)]
    assert sum("tracking" in c.failed for c in weak) <= 5
    # missed by 1000 half-widths (β = 50, z ≈ 8.7): flagged every time, as caution
    strong = [_window(rng, 300, 1000.0) for _ in range(50)]
    assert all("tracking" in c.failed and c.verdict == CAUTION for c in strong)
    assert TRACKING_Z == 3.0


def test_growing_table_is_exact_and_readable_before_it_is_closed(tmp_path):
    import pandas as pd
    rng = np.random.default_rng(0)
    rows = rng.normal(size=(50, 3)) * 10.0 ** rng.integers(-12, 12, size=(50, 3))
    table = GrowingTable(tmp_path / "rec.csv", ["time_s", "angle_rad", "torque_Nm"], units=["s", "rad", "Nm"],
                         metadata={"stream": "x"})
    table.append(rows[:20])
    table.flush()
    partial = pd.read_csv(tmp_path / "rec.csv.partial", comment="#", skiprows=[1 + 1])
    assert len(partial) == 20
    table.append(rows[20:])
    path = table.close()
    assert path == tmp_path / "rec.csv" and not (tmp_path / "rec.csv.partial").exists()
    back = np.loadtxt(path, delimiter=",", comments="#", skiprows=3)
    np.testing.assert_array_equal(back, rows)        # shortest round-trip text: the same float64
    with pytest.raises(ValueError, match="3 columns"):
        GrowingTable(tmp_path / "other.csv", ["a", "b", "c"]).append(np.zeros((1, 2)))


@pytest.mark.slow
def test_samples_missing_inside_a_chunk_are_bridged_too(ramp_trial):
    y, f, _, fs = ramp_trial
    n = 9000
    t = np.arange(n) / fs
    keep = np.ones(n, dtype=bool)
    keep[7003:7010] = False                      # inside one 100-sample chunk
    whole = LiveSession(fs, Immediately())
    _replay(whole, y[:n][keep], f[:n][keep], fs, times=t[keep], chunk=100)
    assert whole.events.dropped_samples == 7 and whole.events.bridged_gaps == 1 and whole.events.breaks == []
    assert whole.record.total == n               # the estimate ran on the bridged samples


def test_the_record_keeps_its_last_samples_and_counts_from_the_segment_start():
    from limbstiff.live.buffers import Record
    record = Record(keep=100)
    values = np.arange(1000.0)
    for i in range(0, 1000, 7):
        record.append(values[i:i + 7], -values[i:i + 7])
    assert record.total == 1000 and 100 <= record.n <= 200     # never more than twice what is kept
    angle, torque = record.last(100)
    np.testing.assert_array_equal(angle, values[-100:])
    np.testing.assert_array_equal(torque, -values[-100:])
    np.testing.assert_array_equal(record.since(950)[0], values[950:])


def test_changing_check_flags_an_estimate_that_moved_more_than_its_band():
    k = 200
    flat = np.full(k, 10.0)
    ramp = np.linspace(10.0, 12.0, k)         # 2 N·m/rad over the window; 0.8 over the last 80 steps
    rng = np.random.default_rng(1)
    e, s, z, y = rng.normal(0, 1, k), np.ones(k), rng.normal(0, 5, k), np.cumsum(rng.normal(0, 0.01, k))
    ones = np.ones(k, bool)

    def check(stiffness, half, memory):
        recent = None if memory is None else stiffness[-1 - memory:]       # the estimate over its memory
        return live_checks(stiffness, stiffness - half, stiffness + half, ones, e, s, z, y, recent=recent)

    assert "changing" not in check(flat, 0.5, 80).failed
    moved = check(ramp, 0.5, 80)              # moved 0.80 over the memory, band half-width 0.5: 1.61
    assert "changing" in moved.failed and moved.moved == pytest.approx(2.0 / 199 * 80 / 0.5, rel=1e-9)
    assert moved.verdict == CAUTION
    assert "changing" not in check(ramp, 1.0, 80).failed     # 0.8 < 1.0
    assert np.isnan(check(ramp, 0.5, None).moved)             # no memory, no check


@pytest.mark.slow
def test_samples_that_are_not_numbers_are_left_out_as_missing(ramp_trial):
    y, f, _, fs = ramp_trial
    n = 9000
    angle = y[:n].copy()
    angle[7005:7008] = np.nan                    # a sensor's dropout inside a chunk
    session = LiveSession(fs, Immediately())
    values, parts = _replay(session, angle, f[:n], fs)
    assert session.events.non_finite == 3 and session.events.dropped_samples == 3
    assert session.events.bridged_gaps == 1 and session.events.samples == n
    assert np.all(np.isnan(values[7005:7008, 0])) and np.all(values[7005:7008, 3] == 0)
    assert np.all(np.isfinite(values[7008:, 0]))            # the estimate goes on, not NaN for ever
    part = parts[700]
    assert part.usable is not None and part.usable.tolist() == [True] * 5 + [False] * 3 + [True] * 2


@pytest.mark.slow
def test_the_direct_variant_needs_no_inertia_or_damping():
    from limbstiff.simulate import simulate
    trial = simulate("paper-exp-spring", seed=1)            # the elastic torque is measured
    session = LiveSession(trial.fs, Immediately(variant="direct"))
    values, _ = _replay(session, trial.angle, trial.elastic_torque, trial.fs)
    first = session.events.identifications[0]
    assert first["inertia"] is None and first["damping"] is None and "error" not in first
    use = np.isfinite(values[:, 0])
    error = np.abs(values[use, 0] / trial.stiffness_true[use] - 1)
    # measured 5.0 %: the paper's spring stiffens with the angle within each cycle, which a causal
    # estimate averages over its memory; 10 % leaves room and still fails a wrong chain (m·ÿ + b·ẏ
    # taken off an elastic torque, or a channel mixed up, is tens of per cent off)
    assert np.median(error) < 0.10


def test_the_recording_time_always_increases_and_reads_back(tmp_path):
    """A sender's clock 50 ppm fast and a clock-offset step of −20 ms (review of issue 38): the
    time on the nominal grid still increases, keeps a real gap, and the file reads as a trial."""
    from limbstiff.files import read_trial
    from limbstiff.files.recording import SegmentedRecording

    fs, n = 1000.0, 12000
    stamps = 50.0 + np.arange(n) / fs * (1 + 5e-5)
    stamps[8000:] -= 0.020                                   # the offset stepped back
    stamps[10000:] += 0.030                                  # 30 samples missing
    (tmp_path / "s-2.csv").write_text("another trial's file\n")
    rec = SegmentedRecording(tmp_path, "s", ["angle_rad", "torque_Nm"], ["rad", "Nm"], {"stream": "x"}, fs)
    t = np.arange(n) / fs
    values = np.column_stack([0.1 * np.sin(2 * np.pi * t), 2.0 * np.sin(2 * np.pi * t)])
    rec.segment(stamps[0])
    rec.append(stamps[:6000], values[:6000])
    rec.append(stamps[6000:], values[6000:])
    rec.segment(99.0)                                        # a break: the next free name
    rec.append(np.array([99.0, 99.001]), values[:2])
    paths = rec.close()
    assert [p.name for p in paths] == ["s.csv", "s-3.csv"]
    assert (tmp_path / "s-2.csv").read_text() == "another trial's file\n"
    time = np.loadtxt(paths[0], delimiter=",", comments="#", skiprows=3)[:, 0]   # 2 metadata lines, header
    assert np.all(np.diff(time) > 0)
    assert np.round(np.diff(time) * fs).max() == 31          # the gap kept: 30 missing samples
    trial = read_trial(paths[0])
    assert trial.n_samples > n                               # the gap bridged, nothing refused


def test_the_recording_headers_carry_their_units():
    from limbstiff.files.recording import unit_headers

    headers, units = unit_headers(["time_s", "angle", "torque_Nm", "channel_2", "k", "marker", "schedule"],
                                  ["s", "deg", "Nm", "N·m", "Nm_per_rad", None, "%MVC"])
    assert headers == ["time_s", "angle_deg", "torque_Nm", "channel_2_N·m", "k_Nm_per_rad", "marker", "schedule_%MVC"]
    assert units is None
    # what cannot be said in a header keeps the headers as given and the unit row
    assert unit_headers(["time_s", "EMG"], ["s", "uV"]) == (["time_s", "EMG"], ["s", "uV"])
    assert unit_headers(["time_s", "angle_deg"], ["s", "rad"]) == (["time_s", "angle_deg"], ["s", "rad"])
    assert unit_headers(["time_s", "angle", "angle_deg"], ["s", "deg", None])[1] == ["s", "deg", ""]


def test_the_recording_is_a_standard_trial_file_read_back_to_the_bit(tmp_path):
    """No unit row (pandas reads floats), shortest round-trip numbers (24.998, not
    24.998000000000001), and limbstiff's reader gives back the values received, to the bit; a
    channel labelled ``angle`` of unit ``deg`` is ``angle_deg``, a protocol's ``channel_1`` found."""
    import pandas as pd

    from limbstiff.files import read_trial
    from limbstiff.files.recording import SegmentedRecording
    from limbstiff.protocol.reading import protocol_from_dict

    fs, n = 200.0, 6000
    rng = np.random.default_rng(3)
    values = np.column_stack([0.3 * np.sin(np.arange(n) / 20) + 1e-3 * rng.normal(size=n),
                              rng.normal(size=n) * 10.0 ** rng.integers(-6, 3, size=n)])
    rec = SegmentedRecording(tmp_path, "r", ["angle_rad", "torque_Nm"], ["rad", "Nm"], {"stream": "x"}, fs)
    rec.segment(10.0)
    rec.append(10.0 + np.arange(n) / fs, values)
    path, = rec.close()
    lines = path.read_text().splitlines()
    assert lines[2] == "time_s,angle_rad,torque_Nm" and lines[3].startswith("0.0,")
    assert any(line.startswith("24.995,") for line in lines)          # not 24.995000000000001
    table = pd.read_csv(path, comment="#")
    assert list(table.dtypes) == [np.float64] * 3
    np.testing.assert_array_equal(table.to_numpy(), np.column_stack([np.arange(n) / fs, values]))
    trial = read_trial(path)
    np.testing.assert_array_equal(trial.angle, values[:, 0])
    np.testing.assert_array_equal(trial.torque, values[:, 1])
    np.testing.assert_allclose(trial.time, np.arange(n) / fs, rtol=0, atol=1e-12)   # the reader's own grid

    rec = SegmentedRecording(tmp_path, "d", ["angle", "channel_1"], ["deg", "Nm"], {"stream": "x"}, fs)
    rec.segment(0.0)
    rec.append(np.arange(n) / fs, values)
    path, = rec.close()
    assert path.read_text().splitlines()[2] == "time_s,angle_deg,channel_1_Nm"
    protocol = protocol_from_dict({"columns": {"torque": {"header": "channel_1"}}})
    trial = read_trial(path, protocol)
    np.testing.assert_allclose(trial.angle, np.deg2rad(values[:, 0]), rtol=1e-15)
    np.testing.assert_array_equal(trial.torque, values[:, 1])


def test_the_status_line_says_the_stream_ended():
    session = LiveSession(100.0, Immediately())
    assert status_line(session, stalled_s=3.2).endswith("| STALLED 3 s")
    assert status_line(session, stalled_s=3.2, ended=True).endswith("| stream ended 3 s ago")


def test_the_analysis_bridges_what_the_session_bridged(tmp_path):
    from types import SimpleNamespace

    from limbstiff.live.run import _analysis_protocol
    from limbstiff.protocol import Protocol

    session = SimpleNamespace(events=SimpleNamespace(longest_bridged_s=0.081), fs=1000.0)
    assert _analysis_protocol(Protocol(), session).max_gap_s == pytest.approx(0.0815)
    given = Protocol(max_gap_s=0.05)                       # the session itself bridged no more than this
    assert _analysis_protocol(given, session) is given
    quiet = SimpleNamespace(events=SimpleNamespace(longest_bridged_s=0.0), fs=1000.0)
    assert _analysis_protocol(Protocol(), quiet).max_gap_s is None
    assert LiveSession(1000.0, Immediately(), max_gap_s=0.05)._longest_gap() == 0.05


def test_identifications_after_a_long_warmup_come_every_minute():
    assert [identification_due(k, warmup_s=90.0) for k in range(3)] == [90.0, 150.0, 210.0]
    assert [identification_due(k, warmup_s=30.0) for k in range(4)] == [30.0, 60.0, 120.0, 180.0]


def test_latency_quantiles_in_constant_memory():
    from limbstiff.live.latency import Histogram
    rng = np.random.default_rng(4)
    values = rng.lognormal(-10, 1.0, 20000)
    hist = Histogram()
    for v in values:
        hist.add(float(v))
    for q in (0.5, 0.99, 0.999):
        # the bin's upper edge: at most one bin (0.5 %) above the exact quantile, never below it
        ratio = hist.quantile(q) / np.quantile(values, q)
        assert 0.995 <= ratio <= 1.006
    assert hist.summary(1.0)["max"] == values.max() and hist.n == 20000


def test_a_step_of_the_clock_offset_is_reported():
    from types import SimpleNamespace

    from limbstiff.live.run import _clock_step
    session = LiveSession(1000.0, Immediately())
    offset = _clock_step(SimpleNamespace(clock_offset=0.0105), 0.0100, session, 12.0)   # half a period: no
    assert offset == 0.0105 and session.events.clock_steps == []
    offset = _clock_step(SimpleNamespace(clock_offset=-0.0100), offset, session, 13.0)
    assert session.events.clock_steps == [{"at_lsl_time_s": 13.0, "step_s": pytest.approx(-0.0205)}]
    assert _clock_step(SimpleNamespace(clock_offset=float("nan")), offset, session, 14.0) == offset


def test_an_empty_window_judges_nothing():
    empty = np.zeros(0)
    checks = live_checks(empty, empty, empty, empty.astype(bool), empty, empty, empty, empty)
    assert checks.verdict == OK and checks.failed == () and np.isnan(checks.motion)
    # asked whether the estimate changes, an empty window cannot tell: not ok on nothing judged
    checks = live_checks(empty, empty, empty, empty.astype(bool), empty, empty, empty, empty, recent=np.full(5, np.nan))
    assert checks.failed == ("settling",) and checks.verdict == CAUTION


def test_huge_finite_values_are_not_taken_for_missing_ones():
    session = LiveSession(1000.0, Immediately())
    big = np.full(10, 1e308)                       # their sum overflows; every one is a number
    published = session.feed(np.arange(10) / 1000.0, big, big)
    assert session.events.non_finite == 0 and published.usable is None


def _published(rng, n, memory, half_width_in_sd):
    """A live course that errs like a causal estimate (AR(1) errors with the memory's correlation,
    sd 1 about a smoothed course) and its band of ``half_width_in_sd`` sd."""
    rho = np.exp(-1.0 / memory)
    error = signal.lfilter([np.sqrt(1 - rho ** 2)], [1, -rho], rng.standard_normal(n))
    smoothed = 50.0 + np.sin(np.arange(n) / 500.0)
    live = smoothed + error
    return smoothed, live - half_width_in_sd, live + half_width_in_sd


def test_hindsight_false_alarm_and_detection_rates():
    """A 90 % band (±1.645 sd) is said too narrow in at most ~2.3 % of records (HINDSIGHT_Z = 2, one
    sided; the binomial limit over span/(2·memory) comparisons is conservative for AR(1) errors, so
    fewer); a band of ±0.8 sd (58 %: truth outside 42 %) is said too narrow in most."""
    rng = np.random.default_rng(38)
    n, memory = 30000, 500                    # 60 s at 500 Hz, a 1 s memory: 30 comparisons
    alarms = {1.645: 0, 0.8: 0}
    outside = {1.645: [], 0.8: []}
    for _ in range(200):
        for width in alarms:
            smoothed, lo, hi = _published(rng, n, memory, width)
            found = hindsight(smoothed, lo, hi, memory_samples=memory, ci_level=0.9)
            alarms[width] += found.too_narrow
            outside[width].append(found.outside)
    # the calibrated band misses 10 % on average (each record's share has sd 0.03, the mean of 200
    # 0.002: ± 1.2 % is six of those, and a band 10 % narrower misses 12.6 %); it is flagged at
    # most at the one-sided 2.3 % (~5 of 200; measured 0: the binomial limit is conservative for
    # correlated errors); a band of ±0.8 sd misses 42.4 % (2·Φ(−0.8)) and is flagged in nearly all
    # (measured 200 of 200; a band of ±1.2 sd, missing 23 %, was flagged in 127)
    assert abs(np.mean(outside[1.645]) - 0.10) < 0.012
    assert alarms[1.645] <= 8
    assert abs(np.mean(outside[0.8]) - 0.424) < 0.02
    assert alarms[0.8] >= 180
    assert found.limit == pytest.approx(0.1 + HINDSIGHT_Z * np.sqrt(0.09 / found.independent))


def test_hindsight_judges_only_informed_published_samples():
    smoothed = np.full(4000, 10.0)
    lo, hi = np.full(4000, 9.0), np.full(4000, 11.0)
    lo[:1000] = hi[:1000] = np.nan            # not published (before an estimate) or not informed
    lo[3000:] = 10.5                          # misses the smoothed course
    found = hindsight(smoothed, lo, hi, memory_samples=100, ci_level=0.9)
    assert found.samples == 3000 and found.outside == pytest.approx(1 / 3)
    assert found.independent == pytest.approx(3000 / 200) and found.too_narrow
    smoothed[2000:] = np.nan                  # the smoother's end: no more future than the live estimate
    assert hindsight(smoothed, lo, hi, memory_samples=100, ci_level=0.9).outside == 0.0
    assert hindsight(smoothed, lo, hi, memory_samples=400, ci_level=0.9) is None    # 1000 samples: 1.25 memories


@pytest.mark.slow
def test_hindsight_flags_the_band_that_lagged_a_ramp():
    """limbstiff's elbow ramps 6 → 30 N·m/rad from 8 to 22 s: the live band lags it and holds the
    truth on about two thirds of the samples (benchmarks/live.py). The look backs (one per refit,
    each over one checks window ending a memory before its record's end) say so from the first
    with two memories to compare (14 s: 58 % outside against a limit of 48 %) to 20 s (74 %), and
    no longer once the window has left the ramp (26 s on: 0–2 %): the flag follows the ramp."""
    from limbstiff.simulate import simulate
    trial = simulate("elbow", seed=100)
    session = LiveSession(trial.fs, Immediately())
    looks = []
    original = session._look_back

    def look_back(smoothed, at):
        found = original(smoothed, at)
        if found is not None:
            looks.append((at / trial.fs, found))
        return found
    session._look_back = look_back
    cut = int(18.5 * trial.fs)          # a look back at 18 s said the band too narrow: the verdict says so
    first, _ = _replay(session, trial.angle[:cut], trial.torque[:cut], trial.fs)
    assert "hindsight" in session.checks.failed and first[-1, 4] == CAUTION.code
    rest, _ = _replay(session, trial.angle[cut:], trial.torque[cut:], trial.fs, times=trial.time[cut:] - trial.time[0])
    values = np.vstack([first, rest])
    flagged = [t for t, found in looks if found.too_narrow]
    assert flagged and 12.0 <= min(flagged) and max(flagged) <= 22.0      # while the ramp is in the window
    assert all(found.outside < 0.1 for t, found in looks if t >= 26.0)        # 4 s after it ended: not
    during = (trial.time > 16.0) & (trial.time < 20.0)
    assert np.all(values[during, 4] == CAUTION.code)
    assert "hindsight" not in session.checks.failed
    at_20 = session.events.identifications[-1]                 # as stream.json says it
    assert at_20["at_samples"] == 20000 and at_20["hindsight"]["too_narrow"]
    assert at_20["hindsight"]["outside"] > at_20["hindsight"]["limit"]


def test_the_published_band_ring_returns_what_was_added_by_position():
    from limbstiff.live.buffers import PublishedBand

    def rows(first, k):             # OUT rows whose lo is the position, hi the position + 0.5, informed
        r = np.full((k, 10), np.nan)
        r[:, 1], r[:, 2], r[:, 3] = np.arange(first, first + k), np.arange(first, first + k) + 0.5, 1.0
        return r
    band = PublishedBand(10)
    band.add(0, rows(0, 7))
    band.add(7, None, 2)            # bridged: not published
    band.add(9, rows(9, 6))         # wraps around the ring
    lo, hi = band.between(3, 15)    # 3, 4 no longer held (15 − 10 = 5 is the first held)
    expect = np.array([np.nan, np.nan, 5, 6, np.nan, np.nan, 9, 10, 11, 12, 13, 14])
    np.testing.assert_array_equal(lo, expect)
    np.testing.assert_array_equal(hi, expect + 0.5)
    band.add(15, rows(15, 23))      # more than the ring holds at once: its last 10
    lo, _ = band.between(25, 38)
    np.testing.assert_array_equal(lo, [np.nan, np.nan, np.nan] + list(range(28, 38)))
    r = rows(38, 2)
    r[0, 3] = 0.0                   # not informed: not judged
    band.add(38, r)
    lo, _ = band.between(38, 40)
    np.testing.assert_array_equal(lo, [np.nan, 39])


def test_a_look_back_that_cannot_be_made_does_not_fail_the_refit(ramp_trial, monkeypatch):
    from limbstiff.live import identify
    y, f, _, fs = ramp_trial
    first = identify.identify_live(y[:20000], f[:20000], fs=fs, memory_periods=2.0)
    assert first.smoothed is not None and np.isfinite(first.smoothed).any()

    def fails(*args, **kwargs):
        raise TrialError("live", "no smoother today")
    monkeypatch.setattr(identify.estimators, "kalman", fails)
    refit = identify.refit_live(y[:22000], f[:22000], previous=first.model, memory_periods=2.0)
    assert refit.smoothed is None and np.isfinite(refit.model.noise.stiffness_walk)


def test_hindsight_counts_no_more_comparisons_than_samples():
    """Intermittent motion: 100 informed samples in two blocks at the ends of a 5000-sample window
    are not 2.5 memories of comparisons (review of this check: one short miss said 'caution')."""
    smoothed = np.full(5000, 10.0)
    lo, hi = np.full(5000, np.nan), np.full(5000, np.nan)
    lo[:50], hi[:50] = 9.0, 11.0
    lo[-50:], hi[-50:] = 10.5, 11.0           # a short miss
    assert hindsight(smoothed, lo, hi, memory_samples=1000, ci_level=0.9) is None
    assert hindsight(smoothed, lo, hi, memory_samples=20, ci_level=0.9).independent == pytest.approx(100 / 40)


def test_the_streams_verdict_codes_are_the_verdicts_severities():
    assert VERDICT_NAMES == {-1: "no estimate yet", 0: "ok", 1: "caution", 2: "unreliable"}
    assert [v.code for v in Verdict] == [0, 1, 2] and Verdict.worst([]) is OK
    assert Verdict.worst([CAUTION, Verdict.UNRELIABLE, OK]) is Verdict.UNRELIABLE
    assert f"{CAUTION}" == "caution" and CAUTION == "caution"


def test_the_live_noise_fit_is_for_the_filter_it_runs_with_its_memory(ramp_trial):
    """The live model's noise levels maximise the likelihood of the filter the session runs, with its
    fading memory, and the levels fitted without the memory maximise the filter without it: each is
    the better of the two under its own filter (up to the optimiser's tolerance, 0.01 in log-likelihood,
    its fatol), and they differ as the memory says they should."""
    from limbstiff.estimate.kalman import fit_noise_levels
    from limbstiff.live import identify
    from limbstiff.statespace.smoother import kalman_loglik

    y, f, _, fs = ramp_trial
    # a memory of half a motion period (2 s), so that it weighs on the fit against the walk
    model = identify.identify_live(y[:20000], f[:20000], fs=fs, memory_periods=0.5).model
    assert model.fading > 0
    rows = LiveEstimator(model).push(y[:20000], f[:20000]).rows
    steps = rows[np.isfinite(rows[:, 5])]
    z, angle, g = steps[:, 7], steps[:, 8], steps[:, 9]
    common = dict(step=model.decimation / fs, deflection=g, initial_mean=(float(z[0]), 0.0),
                  initial_cov=(model.initial_cov[0], 0.0, model.initial_cov[1]))
    increments = np.diff(angle, prepend=angle[0])
    without, _ = fit_noise_levels(increments, z, guess=model.noise, motion_frequency=model.motion_hz, **common)

    def loglik(noise, fading):
        return kalman_loglik(increments, z, noise, fading=fading, **common)

    assert loglik(model.noise, model.fading) >= loglik(without, model.fading) - 0.01
    assert loglik(without, 0.0) >= loglik(model.noise, 0.0) - 0.01
    # the memory adds to the stiffness's variance what the walk would: the walk fitted with it is
    # smaller, by more than the optimiser's resolution (0.02 in log level, its xatol)
    assert np.log(without.stiffness_walk) - np.log(model.noise.stiffness_walk) > 0.05
