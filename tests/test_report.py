"""PDF reports: pages, document metadata, every plot carries data, legible fonts, the batch overview."""

import dataclasses
import hashlib
import json
import platform
import re
import subprocess
import sys

import numpy as np
import pytest

import limbstiff
from limbstiff.mechanics.posterior import Posterior
from limbstiff.provenance import dependencies_text, dependency_versions, settings_hash, software
from limbstiff.simulate import simulate

from .conftest import multisine_trial

matplotlib = pytest.importorskip("matplotlib")

from limbstiff.report import batch_figures, report_figures, write_batch_overview, write_report  # noqa: E402
from limbstiff.report.batch import TRIALS_PER_PAGE, order_rows  # noqa: E402
from limbstiff.report.common import MIN_FONT, TEXT_PANEL, page_fonts, style  # noqa: E402

UNITS = {"stiffness": "N·m/rad", "inertia": "kg·m²", "damping": "N·m·s/rad"}


def page_count(pdf: bytes) -> int:
    """Page objects of a PDF (matplotlib writes them uncompressed): /Type /Page, not /Pages."""
    return len(re.findall(rb"/Type\s*/Page(?![A-Za-z])", pdf))


def has_data(ax) -> bool:
    """An axes shows data: a line with ≥ 2 finite points, scatter points, a collection with a
    finite path (band, bars, contour, colour bar), an image, or a bar/histogram patch (bars or a
    filled step outline). Reference lines and spans (axvline, axvspan: not in data coordinates) do
    not count."""
    from matplotlib.collections import PathCollection
    from matplotlib.patches import Polygon, Rectangle
    for line in ax.get_lines():
        x, y = (np.asarray(v, dtype=float) for v in line.get_data())
        if line.get_transform() is ax.transData and np.count_nonzero(np.isfinite(x) & np.isfinite(y)) >= 2:
            return True
    for coll in ax.collections:
        if isinstance(coll, PathCollection):
            offsets = np.asarray(coll.get_offsets(), dtype=float).reshape(-1, 2)
            if np.isfinite(offsets).all(axis=1).any():
                return True
        elif any(len(p.vertices) >= 2 and np.isfinite(p.vertices).all() for p in coll.get_paths()):
            return True
    if ax.images:
        return True
    if any(isinstance(p, Polygon) and p.get_data_transform() is ax.transData and len(p.get_xy()) >= 3
           and np.isfinite(p.get_xy()).all() and np.ptp(p.get_xy()[:, 1]) > 0 for p in ax.patches):
        return True
    return any(isinstance(p, Rectangle) and p.get_data_transform() is ax.transData and p.get_height() > 0
               and p.get_width() > 0 for p in ax.patches)


def check_figures(figures):
    """Every axes has data or is marked as holding text only; no text panel is empty; every text is
    at least MIN_FONT."""
    from matplotlib.text import Text
    for k, fig in enumerate(figures, start=1):
        assert tuple(np.round(fig.get_size_inches(), 2)) == (8.27, 11.69), f"page {k} is not A4 portrait"
        for ax in fig.axes:
            if ax.get_gid() == TEXT_PANEL:
                assert ax.texts, f"page {k}: an empty text panel"
                continue
            assert has_data(ax), f"page {k}: axes {ax.get_xlabel()!r}/{ax.get_ylabel()!r} shows no data"
        for text in fig.texts:
            assert text.get_gid() != TEXT_PANEL or text.get_text().strip(), f"page {k}: an empty text panel"
        for text in fig.findobj(Text):
            if text.get_visible() and text.get_text().strip():
                assert text.get_fontsize() >= MIN_FONT, f"page {k}: {text.get_text()!r} in {text.get_fontsize()} pt"


def labels(figures) -> str:
    return " ".join(ax.get_xlabel() + " " + ax.get_ylabel() for fig in figures for ax in fig.axes)


@pytest.fixture(scope="module")
def elbow():
    trial = simulate("elbow", seed=3, params={"duration": 10.0})
    return limbstiff.analyze(trial, seed=0)


@pytest.fixture(scope="module")
def fixed():
    return limbstiff.analyze(multisine_trial(duration=4.0), inertia=0.06, damping=0.45, seed=0)


@pytest.mark.slow
def test_trial_report_pages_metadata_and_data(elbow, tmp_path):
    assert elbow.posterior is not None and elbow.reference is not None
    path = write_report(elbow, tmp_path / "report.pdf")
    pdf = path.read_bytes()
    assert pdf.startswith(b"%PDF")
    assert page_count(pdf) == 6          # summary, time, relations, posterior, quality, reference
    assert b"/Title (limbstiff stiffness report: elbow)" in pdf
    assert f"/Creator (limbstiff {limbstiff.__version__})".encode() in pdf
    assert b"/Subject (" in pdf
    assert not list(tmp_path.glob(".*.tmp"))        # written atomically, no temporary left
    figures = report_figures(elbow)
    check_figures(figures)
    text = labels(figures)
    for unit in ("[rad]", "[N·m]", "[N·m/rad]", "[kg·m²]", "[N·m·s/rad]", "[Hz]", "[s]", "[%]"):
        assert unit in text
    footers = [t.get_text() for fig in figures for t in fig.texts if t.get_text().startswith("limbstiff ")]
    assert len(footers) == len(figures)
    settings = elbow.summary()["settings_sha256"][:12]
    assert settings == elbow.settings_sha256[:12]
    assert all(settings in f and "numpy" in f and "seed 0" in f for f in footers)


@pytest.mark.slow
def test_standard_fonts_where_the_text_fits_them(elbow, tmp_path):
    """Pages whose text fits WinAnsi are written in Helvetica (not embedded: the fast path); a page
    with another character falls back to the embedded DejaVu font rather than print "?"."""
    with style():                                       # as write_pdf calls it: ASCII minus signs
        assert [page_fonts(fig) for fig in report_figures(elbow)] == [{}] * 6
    pdf = write_report(elbow, tmp_path / "latin.pdf").read_bytes()
    assert b"/BaseFont /Helvetica" in pdf
    greek = dataclasses.replace(elbow, trial=dataclasses.replace(elbow.trial, name="σ-голень"))
    assert all(page_fonts(fig) == {"pdf.use14corefonts": False} for fig in report_figures(greek))  # name in every footer
    pdf = write_report(greek, tmp_path / "greek.pdf").read_bytes()
    assert b"/BaseFont /Helvetica" not in pdf and b"DejaVuSans" in pdf


def test_fonts_look_at_tick_labels_set_as_text():
    """Tick labels set as strings are text like any other (page_fonts skips only the formatted
    numbers, to avoid creating every tick before drawing)."""
    from matplotlib.figure import Figure
    fig = Figure()
    ax = fig.add_subplot()
    ax.set_xticks([0, 1], ["left", "right"])
    ax.set_ylabel("stiffness [N·m/rad]")                 # "·" is in WinAnsi
    assert page_fonts(fig) == {}
    ax.set_xticks([0, 1], ["left", "σ"])
    assert page_fonts(fig) == {"pdf.use14corefonts": False}
    ax.set_xticks([0, 1], ["left", "right"])
    ax.legend(handles=ax.plot([0, 1], label="τ_ext"))   # a legend's text is reached too
    assert page_fonts(fig) == {"pdf.use14corefonts": False}


def test_fixed_inertia_and_damping_say_so(fixed):
    assert fixed.posterior is None
    figures = report_figures(fixed)
    assert len(figures) == 6                       # the synthetic trial has a reference
    check_figures(figures)
    posterior_page = figures[3]
    assert not posterior_page.axes                 # the page is a text panel: the figure's texts
    panel = " ".join(t.get_text() for t in posterior_page.texts if t.get_gid() == TEXT_PANEL)
    assert "No posterior of inertia and damping" in panel and "given, not identified" in panel


@pytest.mark.slow
def test_direct_translational_trial():
    result = limbstiff.analyze(simulate("paper-exp-spring", seed=1, params={"duration": 4.0}), seed=0)
    assert result.variant == "direct" and result.trial.kind == "translational"
    figures = report_figures(result)
    check_figures(figures)
    text = labels(figures)
    assert "[N/m]" in text and "position [m]" in text and "elastic force [N]" in text
    assert "N·m" not in text


@pytest.mark.slow
def test_unobservable_constant_torque_and_one_fixed_parameter(fixed, elbow, tmp_path):
    """Degenerate results still give a complete report: nothing informed, a constant torque."""
    n = fixed.trial.n_samples
    trial = dataclasses.replace(fixed.trial, torque=np.full(n, 0.3), stiffness_true=None)
    result = dataclasses.replace(fixed, trial=trial, observable=np.zeros(n, bool), reference=None,
                                 stiffness=np.full(n, 12.0), stiffness_lo=np.full(n, 12.0),
                                 stiffness_hi=np.full(n, 12.0))
    figures = report_figures(result)
    assert len(figures) == 5                       # no reference page
    check_figures(figures)
    assert page_count(write_report(result, tmp_path / "r.pdf").read_bytes()) == 5
    # damping given, inertia identified: the draws' damping column is constant
    draws = elbow.posterior.draws.copy()
    draws[:, 1] = 0.45
    ident = dataclasses.replace(elbow.identification, posterior=Posterior(draws, elbow.posterior.diagnostics),
                                damping=limbstiff.result.Interval.fixed(0.45))
    one = dataclasses.replace(elbow, identification=ident, damping=ident.damping)
    check_figures([report_figures(one)[3]])


def _ok_row(name, k, **meta):
    return {"trial": name, "status": "ok", "stiffness": {"median": k, "lo": 0.9 * k, "hi": 1.1 * k},
            "inertia": {"median": 0.06, "lo": 0.055, "hi": 0.065}, "damping": {"median": 0.4, "lo": 0.35, "hi": 0.45},
            "observable_fraction": 0.9, "metadata": meta, "units": UNITS}


def test_batch_overview(tmp_path):
    rows = [_ok_row("t3", 20.0, subject="S10", condition="b"), _ok_row("t1", 10.0, subject="S2", condition="a"),
            _ok_row("t2", 15.0, subject="S2"), _ok_row("t4", 30.0, condition="a"),
            dict(_ok_row("direct", 40.0, subject="S2", condition="a"), inertia=None, damping=None),
            {"trial": "bad", "status": "failed", "error": "bad.csv: time is not strictly increasing at sample 7"}]
    ordered = [r["trial"] for r in order_rows(rows, ["subject", "condition"])]
    # S2 before S10 (natural order); a missing key sorts last; failed rows lack metadata
    assert ordered == ["direct", "t1", "t2", "t3", "t4", "bad"]
    assert [r["trial"] for r in order_rows(rows)] == ["bad", "direct", "t1", "t2", "t3", "t4"]
    figures = batch_figures(rows, sort_by=["subject", "condition"])
    assert len(figures) == 2                       # one plot page, one table page
    check_figures(figures)
    page = " ".join(t.get_text() for fig in figures for t in fig.texts)
    assert "subject: S2 · condition: a" in page and "time is not strictly increasing" in page
    ticks = [t.get_text() for t in figures[0].axes[0].get_yticklabels()]
    assert ticks == ["direct", "t1", "t2", "t3", "t4"]
    path = write_batch_overview(rows, tmp_path / "overview.pdf", sort_by=["subject", "condition"])
    pdf = path.read_bytes()
    assert page_count(pdf) == 2 and b"/Title (limbstiff batch overview: 6 trials)" in pdf


def test_batch_overview_paginates_and_survives_all_failed():
    rows = [_ok_row(f"trial{i:03d}", 5.0 + i % 37, subject=f"S{i % 9}") for i in range(200)]
    figures = batch_figures(rows, sort_by=["subject"])
    plots = [f for f in figures if f.axes]
    assert len(plots) == 5
    for fig in plots:
        assert 0 < len(fig.axes[0].get_yticks()) <= TRIALS_PER_PAGE
    failed = batch_figures([{"trial": "x", "status": "failed", "error": "no"}])
    check_figures(failed)


def test_provenance():
    versions = dependency_versions()
    assert {"numpy", "scipy", "pandas", "emcee", "matplotlib"} <= set(versions)
    assert versions["numpy"] == np.__version__
    versions["numpy"] = "changed"
    assert dependency_versions()["numpy"] == np.__version__          # cached values are not shared
    block = software()
    assert block == {"name": "limbstiff", "version": limbstiff.__version__, "python": platform.python_version(),
                     "dependencies": dependency_versions()}
    assert dependencies_text(block).startswith(f"numpy {np.__version__}, scipy ")
    settings = {"b": 1, "a": [1, 2], "c": {"z": None}}
    assert settings_hash(settings) == hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:12]


@pytest.mark.slow
def test_analysis_does_not_import_matplotlib():
    code = ("import sys, limbstiff, limbstiff.analysis, limbstiff.provenance, limbstiff.result; "
            "limbstiff.provenance.dependency_versions(); "
            "assert 'matplotlib' not in sys.modules, 'matplotlib imported'")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_page_one_is_the_answer(elbow):
    """Page 1 carries the verdict, the stiffness-over-time figure and the trial's figures."""
    page = report_figures(elbow)[0]
    words = " ".join(t.get_text() for t in page.texts)
    assert "Verdict: OK" in words and "Median stiffness" in words and "90 % interval of the median" in words
    assert len(page.axes) == 1 and page.axes[0].get_ylabel() == "stiffness [N·m/rad]"
    assert "not informed by motion" in [t.get_text() for t in page.axes[0].get_legend().get_texts()]


def test_result_draws_into_a_users_axes_and_prints_page_one(elbow):
    from matplotlib.figure import Figure
    fig = Figure()
    axes = fig.subplots(1, 3)
    for ax, against in zip(axes, ("time", "angle", "torque")):
        assert elbow.plot(ax=ax, against=against) is ax
        assert has_data(ax)
    assert axes[1].get_xlabel() == "angle [rad]" and axes[2].get_xlabel() == "torque [N·m]"
    with pytest.raises(ValueError, match="against"):
        elbow.plot(ax=axes[0], against="speed")
    text = elbow.report()
    median = elbow.informed_stiffness()[0]
    assert text.splitlines()[0] == "Stiffness of trial elbow"
    assert f"Verdict: {elbow.verdict.upper()}" in text and f"{median.median:.4g} N·m/rad" in text
    assert repr(elbow).startswith("<StiffnessResult 'elbow': median stiffness") and "informed>" in repr(elbow)


def test_relation_bins_exact():
    """Bins of equal counts: on x = 0…299 (given in reverse) with stiffness = x in ten bins, each
    median is the middle of its 30 values (start + 14.5) and the 10th/90th percentiles lie 11.6
    from it (numpy's linear rule: the 10th percentile of 0…29 is 2.9)."""
    from limbstiff.report.plots import relation_bins
    x = np.arange(300.0)[::-1]
    b = relation_bins(x, x, x - 1, x + 2, bins=10)
    starts = np.arange(0, 300, 30)
    np.testing.assert_allclose(b.x, starts + 14.5)
    np.testing.assert_allclose(b.median, starts + 14.5)
    np.testing.assert_allclose(b.p90 - b.median, 11.6)
    np.testing.assert_allclose(b.median - b.p10, 11.6)
    np.testing.assert_allclose(b.hi - b.lo, 3.0)
    assert b.count.tolist() == [30] * 10
    assert relation_bins(x[:89], x[:89], x[:89], x[:89], bins=10).count.size == 2   # ≥ 30 samples a bin


def test_prior_densities_integrate_to_one():
    """The densities drawn on the posterior page are normalised (trapezoid rule to 1e-3 over a
    range holding all but ~1e-6 of the mass), and the flat default has none."""
    from limbstiff.mechanics.posterior import prior_density
    from limbstiff.protocol import Prior
    x = np.linspace(1e-9, 10.0, 400_001)
    for prior in (Prior("lognormal", median=1.0, sigma=0.5), Prior("halfnormal", scale=2.0),
                  Prior("uniform", low=0.5, high=3.0)):
        assert abs(np.trapezoid(prior_density(x, prior), x) - 1) < 1e-3, prior
    assert prior_density(x, Prior()) is None


@pytest.mark.slow
def test_stiffness_against_angle_follows_a_known_spring():
    """paper-exp-spring narrowed to 1.0–1.6 cm and swept from 1 Hz (10 s, noise-free): k(θ) =
    a·b·e^(b·θ), b = 100/m, rises 1.8-fold over the range. The curve is a parabola in the deflection
    (the angle terms); about the centre the exponential's Taylor series beyond its square term is at
    most R = k(centre)·e^x·x³/6, x = b·(half-range) (Lagrange remainder), so the curve may be off by R
    plus its own band's half-width, no more (measured: 0.80 of that at worst, the rise 0.97 of the
    truth's). Why not the default 0.25–2.25 cm from 0.1 Hz: a 7-fold exponential, where R is a third
    of the stiffness, and a sweep's slow start, where the deflection (the angle less its moving
    average over four typical periods) is not the excursion about the centre."""
    from limbstiff.report.plots import angle_figure
    from limbstiff.report.trial import report_figures
    from limbstiff.simulate.paper import EXP_SPRINGS

    lo, hi = 0.010, 0.016
    result = limbstiff.analyze(simulate("paper-exp-spring", params={"duration": 10.0, "position_min": lo,
                                                                    "position_max": hi, "f_start": 1.0}), seed=0)
    c = angle_figure(result).course
    a, b = EXP_SPRINGS[1][0], 100.0 * EXP_SPRINGS[1][1]
    true = a * b * np.exp(b * c.angle)
    centre = 0.5 * (lo + hi)
    assert c.operating == pytest.approx(centre, abs=0.02 * (hi - lo))
    x = b * float(np.max(np.abs(c.angle - centre)))
    remainder = a * b * np.exp(b * centre) * np.exp(x) * x ** 3 / 6
    assert np.all(np.abs(c.stiffness - true) <= remainder + (c.hi - c.lo) / 2)
    assert (c.stiffness[-1] - c.stiffness[0]) / (true[-1] - true[0]) == pytest.approx(1.0, abs=0.05)
    # drawn on page 3, under the binned relations, from the same numbers
    page = report_figures(result)[2]
    ax = page.axes[2]
    curve = next(line for line in ax.get_lines() if line.get_label().startswith("stiffness against"))
    assert np.allclose(curve.get_xdata(), c.angle) and np.allclose(curve.get_ydata(), c.stiffness)
    assert "rises from" in ax.get_title(loc="left")
    check_figures([page])


def test_stiffness_against_angle_is_flat_without_an_angle_dependence(elbow):
    # the simulated elbow's stiffness ramps in time, not with the angle: the curve stays within its
    # band of one level (the course's median), and page 3 says so
    from limbstiff.estimate.observer import informed_samples
    from limbstiff.report.pages import angle_rows, relation_page
    from limbstiff.report.plots import angle_figure

    assert elbow.checks["angle_dependence"].passed
    c = angle_figure(elbow).course
    assert np.ptp(c.stiffness) < np.min(c.hi - c.lo) / 2
    level = np.median(elbow.stiffness[informed_samples(elbow.observable)])
    assert np.all((c.lo < level) & (level < c.hi))
    with style():
        fig = relation_page(elbow)
    assert len(fig.axes) == 3 and "does not change with the angle beyond its band" in fig.axes[2].get_title(loc="left")
    assert angle_rows(elbow) == []               # page 1 speaks of it only when the check flags it


def test_no_stiffness_against_angle_without_the_angle_terms():
    # another estimator fits no angle terms: no curve, page 3 as before
    from limbstiff.report.pages import relation_page
    from limbstiff.report.plots import angle_figure

    result = limbstiff.analyze(multisine_trial(duration=4.0), inertia=0.06, damping=0.45, seed=0,
                               estimator="observer-smoothed")
    assert angle_figure(result) is None
    with style():
        assert len(relation_page(result).axes) == 2


def _fake_result(stiffness, observable, *, fs=100.0, motion_hz=2.0, decimation=5, edge=4):
    """What :func:`limbstiff.digest.cycle_course` reads of a result."""
    from types import SimpleNamespace
    n = stiffness.size
    return SimpleNamespace(stiffness=stiffness, stiffness_lo=stiffness - 10.0, stiffness_hi=stiffness + 10.0,
                           observable=observable, trial=SimpleNamespace(fs=fs, time=np.arange(n) / fs,
                                                                        units={"stiffness": "N·m/rad"}),
                           filtered=SimpleNamespace(motion_hz=motion_hz, edge=edge),
                           fit=SimpleNamespace(decimation=decimation),
                           informed_stiffness=lambda: (None, float(np.min(stiffness)), float(np.max(stiffness))))


def test_cycle_course_is_one_median_per_motion_period_over_informed_samples():
    """A course that swings sample by sample is drawn, and its range taken, at one value per motion
    period (50 samples here, whole Kalman steps of 5); uninformed cycles and the filter's edge
    samples (here a wild start) have no say."""
    from limbstiff.digest import cycle_course, range_text
    n = 500
    stiffness = 50.0 + np.where(np.arange(n) % 2 == 0, 100.0, -100.0) + np.repeat(np.arange(10.0), 50)
    stiffness[:4] = 1e4                                        # the smoother's start, within the edge
    observable = np.ones(n, bool)
    observable[100:150] = False                                # one cycle not informed
    observable[200:230] = False                                # most of another
    course = cycle_course(_fake_result(stiffness, observable))
    assert course.seconds == pytest.approx(0.5) and course.time.size == 10
    expected = 50.0 + np.arange(10.0)
    informed = np.ones(10, bool)
    informed[[2, 4]] = False
    np.testing.assert_array_equal(course.informed, informed)
    np.testing.assert_allclose(course.stiffness[informed], expected[informed])
    assert np.isnan(course.stiffness[~informed]).all()
    np.testing.assert_allclose(course.hi - course.lo, np.where(informed, 20.0, np.nan))
    text = range_text(_fake_result(stiffness, observable))
    assert text.startswith("50 to 59 N·m/rad") and "8 informed cycles" in text


def test_cycle_course_of_a_trial_without_motion_draws_everything_uninformed():
    from limbstiff.digest import cycle_course, range_text
    result = _fake_result(np.full(200, 7.0), np.zeros(200, bool), motion_hz=float("nan"))
    course = cycle_course(result)
    assert course.time.size == 40 and not course.informed.any() and np.isfinite(course.stiffness[1:-1]).all()
    assert "no cycle is informed" in range_text(result) or "none is informed" in range_text(result)


def test_page_one_draws_the_course_per_cycle_and_fills_the_page(elbow):
    """Page 1's course: one point per motion cycle, its limits those of the informed cycles (no
    tall band at the start); the text between the plot and the footer, the page used to its foot."""
    from limbstiff.digest import cycle_course
    from limbstiff.report.common import FOOTER_HEIGHT
    page = report_figures(elbow)[0]
    ax = next(ax for ax in page.axes if ax.get_ylabel().startswith("stiffness"))
    course = cycle_course(elbow)
    assert any(line.get_xdata().size == course.time.size for line in ax.get_lines())
    band = course.hi[course.informed].max() - course.lo[course.informed].min()
    lo, hi = ax.get_ylim()
    assert hi - lo < 2 * band and hi - lo < (elbow.stiffness_hi - elbow.stiffness_lo).max() + band
    legend = ax.get_legend()
    assert legend.get_bbox_to_anchor().y0 >= ax.get_position().y1 - 1e-9 or legend._loc == 3
    below = [t.get_position()[1] for t in page.texts
             if 0.02 < t.get_position()[1] < ax.get_position().y0]            # not the footer
    assert below and min(below) > FOOTER_HEIGHT
    lowest = min(min(below), *(a.get_position().y0 for a in page.axes))
    assert lowest < 0.3, "the bottom of page 1 is left empty"
    assert "lowest and highest median over one motion cycle" in " ".join(t.get_text() for t in page.texts)


def test_two_panel_figure_keeps_its_legend_to_its_own_panel(elbow, tmp_path):
    """The README's figure: the course's legend stays above its own panel, the x labels inside the image."""
    import matplotlib.pyplot as plt
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.5), layout="constrained")
    try:
        elbow.plot(ax=left)
        elbow.plot(ax=right, against="angle")
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        legend = left.get_legend().get_window_extent(renderer)
        assert legend.x1 <= right.get_window_extent(renderer).x0
        assert not legend.overlaps(left.get_window_extent(renderer).shrunk(1.0, 0.9))
        for ax in (left, right):
            label = ax.xaxis.label.get_window_extent(renderer)
            assert label.y0 >= 0 and label.x1 <= fig.bbox.x1
    finally:
        plt.close(fig)


def test_text_panel_is_the_pages_text_from_the_top_of_its_box():
    """A text panel draws no axes: its title at the top left of its grid cell, the keys and values
    below it (the values at ``key_width`` of the cell's width)."""
    from limbstiff.report.common import FONT, grid, new_page, text_panel
    with style():
        fig = new_page()
        gs = grid(fig, 2, 2)
        text_panel(fig, gs[1, 1], [("rate", "1000 Hz"), ("samples", "60001")], title="Sampling", key_width=0.3)
    assert not fig.axes
    texts = [t for t in fig.texts if t.get_gid() == TEXT_PANEL]
    assert [t.get_text() for t in texts] == ["Sampling", "rate\nsamples", "1000 Hz\n60001"]
    box = gs[1, 1].get_position(fig)
    x0, top = fig.transFigure.transform((box.x0, box.y1))
    width = box.width * fig.bbox.width
    at = [t.get_transform().transform(t.get_position()) for t in texts]
    down = 2.0 * FONT["heading"] / 72 * fig.dpi
    np.testing.assert_allclose(at, [(x0, top), (x0, top - down), (x0 + 0.3 * width, top - down)])
    assert all(t.get_va() == "top" for t in texts)


def test_fixed_ticks_are_the_ones_drawn_with_their_labels():
    """fix_ticks keeps the ticks matplotlib draws, labelled as it labels them, and drops those
    beyond the limits; an axis whose labels need an offset is left to matplotlib."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator
    from limbstiff.report.ticks import fix_ticks

    def drawn(axis):
        return [(t.get_loc(), t.label1.get_text()) for t in axis._update_ticks()]

    fig = Figure()
    ax, log = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
    ax.plot([0.3, 7.7], [1e6 + 1, 1e6 + 2])
    ax.set_xlim(0.3, 7.7)
    ax.xaxis.set_major_locator(MaxNLocator(5))
    log.loglog([0.3, 400], [1e-4, 2])
    log.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    with style():
        before = [drawn(a) for a in (ax.xaxis, log.xaxis, log.yaxis)]
        assert len(ax.xaxis.get_majorticklocs()) > len(before[0])          # some beyond the limits
        for axis in (ax.xaxis, ax.yaxis, log.xaxis, log.yaxis):
            fix_ticks(axis)
        assert [drawn(a) for a in (ax.xaxis, log.xaxis, log.yaxis)] == before
    assert len(ax.xaxis.get_majorticklocs()) == len(before[0])
    assert isinstance(log.yaxis.get_major_locator(), FixedLocator)
    assert not isinstance(ax.yaxis.get_major_locator(), FixedLocator)     # labels with an offset


def test_page_one_glosses_its_words(elbow):
    """Issue 47: "informed", "background torque" and the slope's unit each glossed in one line,
    on page 1 and in the text report; the course's points are per motion cycle (no curve)."""
    from limbstiff.digest import BACKGROUND_GLOSS, INFORMED_GLOSS
    page = report_figures(elbow)[0]
    words = " ".join(t.get_text() for t in page.texts)
    slope = "(N·m/rad)/(N·m): how much the stiffness rises per N·m of background torque"
    for gloss in (INFORMED_GLOSS, BACKGROUND_GLOSS, slope):
        assert gloss.split(":")[0] in words and gloss in words.replace("\n", " ")
        assert gloss in " ".join(elbow.report().split())
    assert "a point per motion cycle of" in page.axes[0].get_xlabel()
    assert "perturbation" not in words + page.axes[0].get_xlabel()


def test_glosses_only_for_the_words_that_appear(elbow):
    from limbstiff.digest import gloss_rows
    assert gloss_rows(elbow, [("Median stiffness", "20 N·m/rad")]) == []
    rows = gloss_rows(elbow, [("Informed by motion", "98 % of the trial")])
    assert [label for label, _ in rows] == ["In plain words"] and rows[0][1].startswith("informed: ")
