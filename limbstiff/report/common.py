"""What every report page shares: page size, fonts, footer, text panels, PDF output.

Pages are :class:`matplotlib.figure.Figure` objects built without pyplot; :func:`write_pdf`
writes a list of them atomically with the document's metadata. matplotlib is imported
inside the functions only.
"""

from __future__ import annotations

import contextlib
import logging
import textwrap
import threading
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from .. import __version__
from ..files.atomic import atomic_output
from ..digest import number

#: The reports' number format.
fmt = number

#: A4 portrait, inches.
A4 = (8.27, 11.69)
#: Smallest font on a page, pt (legible when printed).
MIN_FONT = 8
#: Font sizes, pt.
FONT = {"body": 9, "small": 8, "heading": 11, "title": 15}
#: Line spacing of text panels, in font sizes.
ROW_SPACING = 1.4
#: gid of the texts of a text panel (:func:`text_panel`) and of an axes that holds text only.
TEXT_PANEL = "text-panel"
#: Part of the page left to the footer (bottom) and the title (top), in figure fractions.
FOOTER_HEIGHT, TITLE_HEIGHT = 0.055, 0.05

_RC = {
    "font.size": FONT["body"], "axes.titlesize": FONT["body"], "axes.labelsize": FONT["body"],
    "xtick.labelsize": FONT["small"], "ytick.labelsize": FONT["small"],
    "legend.fontsize": FONT["small"], "figure.titlesize": FONT["heading"],
    "axes.grid": True, "grid.color": "0.9", "grid.linewidth": 0.5, "pdf.fonttype": 3,
    # Helvetica, one of the PDF's 14 standard fonts: every viewer has it, nothing to embed, and its
    # text is written whole (a TrueType font is laid out and tracked glyph by glyph in Python:
    # profiled, 40 % of a trial report's time); pages with other characters: see page_fonts
    "pdf.use14corefonts": True, "axes.unicode_minus": False,
}

#: The standard fonts' encoding (WinAnsi): a page whose text needs another character is drawn
#: with the embedded TrueType font instead.
CORE_ENCODING = "cp1252"


class _WeightNotice(logging.Filter):
    """Drops matplotlib's notice that Helvetica's metrics say "medium" where "normal" was asked."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith("findfont: Failed to find font weight")


#: rc_context changes matplotlib's global settings: reports drawn in threads of one process (a
#: threaded dask worker) take turns, so that none draws with another's settings half undone.
_STYLE_LOCK = threading.RLock()


@contextlib.contextmanager
def style():
    """Font sizes, fonts and grid of the reports, for the figures built and drawn inside the block."""
    import matplotlib
    notice = _WeightNotice()
    log = logging.getLogger("matplotlib.font_manager")
    with _STYLE_LOCK, matplotlib.rc_context(_RC):
        log.addFilter(notice)
        try:
            yield
        finally:
            log.removeFilter(notice)


def page_fonts(fig) -> dict:
    """rc settings for drawing ``fig``: the standard fonts when its text fits their encoding.

    A line of mathtext (between ``$``) is drawn by matplotlib's own fonts in either case; tick
    labels are looked at as they will be formatted (with ASCII minus signs under :data:`_RC`).

    Returns
    -------
    dict
        ``{"pdf.use14corefonts": False}`` when some line would otherwise print as "?".
    """
    from matplotlib.cbook import is_math_text
    for text, parse_math in _set_texts(fig):
        for line in text.split("\n"):
            if not (parse_math and is_math_text(line)):
                try:
                    line.encode(CORE_ENCODING)
                except UnicodeEncodeError:
                    return {"pdf.use14corefonts": False}
    return {}


def _set_texts(artist):
    """(string, whether it is parsed as mathtext) of the visible texts of ``artist`` and its
    children, an axis's tick labels as formatted (parsed as the rc settings say).

    ``Figure.findobj`` would reach the tick labels through ``Axis.get_children``, which creates
    every tick before the page is drawn (profiled: a fifth of a report's time); formatting the
    locations costs a few milliseconds.
    """
    import matplotlib
    from matplotlib.axis import Axis
    from matplotlib.text import Text
    if isinstance(artist, Axis):
        yield from ((t.get_text(), t.get_parse_math()) for t in (artist.label, artist.offsetText) if t.get_visible())
        parse = matplotlib.rcParams["text.parse_math"]
        yield from ((label, parse) for label in artist.get_major_formatter().format_ticks(artist.get_majorticklocs()))
        return
    if isinstance(artist, Text) and artist.get_visible():
        yield artist.get_text(), artist.get_parse_math()
    for child in artist.get_children():
        yield from _set_texts(child)


def new_page(title: str | None = None):
    """An A4 portrait figure with a title; plots go in :func:`grid` (a fixed layout: the
    constrained layout cost more than the analysis on long trials).

    Parameters
    ----------
    title : str, optional
        Page heading (bold, top left).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure
    fig = Figure(figsize=A4)
    if title:
        fig.text(0.06, 1 - 0.6 * TITLE_HEIGHT, title, fontsize=FONT["title"] - 2, weight="bold", va="center")
    return fig


def grid(fig, nrows: int, ncols: int, **kw):
    """A grid of plots filling the page between title and footer, with room for axis labels.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    nrows, ncols : int
    **kw
        Passed to :meth:`~matplotlib.figure.Figure.add_gridspec` (``hspace``, ``height_ratios``…).

    Returns
    -------
    matplotlib.gridspec.GridSpec
    """
    frame = {"left": 0.11, "right": 0.94, "bottom": FOOTER_HEIGHT + 0.045, "top": 1 - TITLE_HEIGHT - 0.02}
    return fig.add_gridspec(nrows, ncols, **{**frame, **kw})


def key_value_lines(key: str, value, wrap: int) -> tuple[list[str], list[str]]:
    """A ``key  value`` row as two columns of lines: the value wrapped at ``wrap`` characters, the key
    on its first line and blanks beside the rest."""
    wrapped = textwrap.wrap(str(value), wrap) or [""]
    return [key] + [""] * (len(wrapped) - 1), wrapped


def text_panel(fig, where, lines: Sequence[tuple[str, str]] | str, *, title: str | None = None,
               fontsize: float = FONT["body"], key_width: float = 0.42, wrap: int = 60) -> None:
    """A panel of text in a box of the page, from its top: a message, or ``key  value`` rows.

    The text is the figure's (gid :data:`TEXT_PANEL`), not an axes': an axes is hundreds of
    artists, made and drawn for nothing here. Lines are spaced in points (:data:`ROW_SPACING` × the font size), so the text keeps
    its spacing whatever the box's height; a box too short for its text lets it run below its
    bottom edge. A value that wraps takes several lines, its key the first.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    where : matplotlib.gridspec.SubplotSpec or (float, float, float, float)
        The box: a cell of a :func:`grid`, or (left, bottom, width, height) in page fractions.
    lines : str or sequence of (str, str)
        A message (wrapped) or rows of a two-column table (values wrapped at ``wrap`` characters).
    title : str, optional
    fontsize : float, pt
    key_width : float
        Fraction of the box's width given to the keys.
    wrap : int
        Characters per line of a value (or the message).
    """
    from matplotlib.transforms import ScaledTranslation

    left, bottom, width, height = where.get_position(fig).bounds if hasattr(where, "get_position") else where

    def text(x, down_pt, s, **kw):
        shift = fig.transFigure + ScaledTranslation(0, -down_pt / 72, fig.dpi_scale_trans)
        fig.text(left + x * width, bottom + height, s, transform=shift, va="top", gid=TEXT_PANEL, **kw)

    down = 0.0
    if title:
        text(0, down, title, fontsize=FONT["heading"], weight="bold")
        down += 2.0 * FONT["heading"]
    if isinstance(lines, str):
        text(0, down, "\n".join(textwrap.wrap(lines, wrap)), fontsize=fontsize, linespacing=ROW_SPACING)
        return
    # two texts, keys and values, each a column of lines: every text is laid out and drawn on its
    # own, and one per cell made the panels' texts most of a report's text
    keys, values = [], []
    for key, value in lines:
        key_lines, value_lines = key_value_lines(key, value, wrap)
        keys += key_lines
        values += value_lines
    for x, column, weight in ((0, keys, "bold"), (key_width, values, "normal")):
        text(x, down, "\n".join(column), fontsize=fontsize, weight=weight, linespacing=ROW_SPACING)


def footer(fig, lines: Iterable[str], page: int | None = None, pages: int | None = None) -> None:
    """Provenance lines at the foot of a page, page number at the right.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    lines : iterable of str
        Each is wrapped to the page's width.
    page, pages : int, optional
        This page's number and the page count.
    """
    text = "\n".join(w for line in lines for w in textwrap.wrap(line, 125))
    fig.text(0.06, 0.012, text, fontsize=MIN_FONT, color="0.35", va="bottom", linespacing=1.3)
    if page is not None:
        fig.text(0.94, 0.012, f"{page} / {pages}" if pages else str(page), fontsize=MIN_FONT, color="0.35",
                 ha="right", va="bottom")


def shade_false(ax, time: np.ndarray, mask: np.ndarray, **kw) -> None:
    """Shade the stretches of ``time`` where ``mask`` is False (grey by default)."""
    pad = np.zeros(1, np.int8)
    false = np.concatenate([pad, (~np.asarray(mask, bool)).view(np.int8), pad])   # one byte a sample
    edges = np.diff(false)
    style_ = {"color": "0.88", "lw": 0, "zorder": 0, **kw}
    for lo, hi in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        ax.axvspan(time[lo], time[min(hi, len(time) - 1)], **style_)


#: Most points of a time-series line on a page: far beyond what print resolves, far below a long trial.
LINE_POINTS = 2000


def envelope(t: np.ndarray, *ys: np.ndarray, points: int = LINE_POINTS, where: np.ndarray | None = None):
    """Thin time series for drawing while keeping every peak: the min and max of each bin.

    Parameters
    ----------
    t : ndarray, shape (n,), s
    *ys : ndarray, shape (n,)
    points : int
        Points per series at most (``points // 2`` bins, each giving its minimum and maximum).
    where : ndarray of bool, shape (n,), optional
        The samples to draw; the others count as NaN (no copy of a series is made for it).

    Returns
    -------
    t, *ys : ndarray
        Unchanged when ``n <= points`` (NaN outside ``where``); else each bin contributes
        (start, min) and (middle, max), which draws the same band of ink as the full series at
        print size. NaNs are ignored within a bin.
    """
    t = np.asarray(t, float)
    n = t.size
    if n <= points:
        return (t, *(_blank(y, where) for y in ys))
    starts = np.linspace(0, n, points // 2 + 1).astype(int)[:-1]
    mids = np.minimum((starts + np.append(starts[1:], n)) // 2, n - 1)
    t_out = np.column_stack([t[starts], t[mids]]).ravel()
    out = [np.column_stack([binned(np.fmin, y, starts, where), binned(np.fmax, y, starts, where)]).ravel()
           for y in ys]
    return (t_out, *out)


def envelope_band(t: np.ndarray, lo: np.ndarray, hi: np.ndarray, points: int = LINE_POINTS,
                  where: np.ndarray | None = None):
    """Thin a band (``fill_between``) for drawing: the lowest ``lo`` and highest ``hi`` per bin
    (samples outside ``where``, when given, counted as NaN).

    Returns
    -------
    t, lo, hi : ndarray
    """
    t = np.asarray(t, float)
    if t.size <= points:
        return t, _blank(lo, where), _blank(hi, where)
    starts = np.linspace(0, t.size, points + 1).astype(int)[:-1]
    return t[starts], binned(np.fmin, lo, starts, where), binned(np.fmax, hi, starts, where)


#: Samples a binned reduction takes at once (see :func:`binned`).
BIN_BLOCK = 1 << 18


def _blank(y: np.ndarray, where: np.ndarray | None) -> np.ndarray:
    y = np.asarray(y, float)
    return y if where is None else np.where(where, y, np.nan)


def binned(reduce, y: np.ndarray, starts: np.ndarray, where: np.ndarray | None = None) -> np.ndarray:
    """``reduce.reduceat(y, starts)`` with ``y`` NaN outside ``where``, NaNs of a bin ignored by
    ``np.fmin``/``np.fmax`` (a bin of NaNs gives NaN): taken over blocks of whole bins of about
    :data:`BIN_BLOCK` samples, so no masked copy of a long series exists at once.

    Parameters
    ----------
    reduce : numpy ufunc
    y : ndarray, shape (n,)
    starts : ndarray of int, shape (m,)
        First sample of every bin, increasing from 0.
    where : ndarray of bool, shape (n,), optional

    Returns
    -------
    ndarray, shape (m,)
    """
    y = np.asarray(y, float)
    out = np.empty(len(starts))
    ends = np.append(starts[1:], y.size)
    first = 0
    with np.errstate(invalid="ignore"):
        while first < len(starts):
            last = max(int(np.searchsorted(starts, starts[first] + BIN_BLOCK)), first + 1)
            lo, hi = starts[first], ends[last - 1]
            part = y[lo:hi] if where is None else np.where(where[lo:hi], y[lo:hi], np.nan)
            out[first:last] = reduce.reduceat(part, starts[first:last] - lo)
            first = last
    return out


def is_constant(x: np.ndarray) -> bool:
    """True when a signal does not change beyond floating-point round-off."""
    x = np.asarray(x, float)
    return bool(np.ptp(x) <= 1e-12 * max(float(np.max(np.abs(x))), 1e-300))


#: Values whose percentiles set an axis's limits at most (evenly thinned beyond: the limits of a
#: long trial are the same within print resolution, at a fraction of the memory).
LIMIT_VALUES = 200_000


def robust_limits(values: np.ndarray, pad: float = 0.15, pct: tuple[float, float] = (1, 99)):
    """Axis limits from percentiles of the finite values, padded; None when there are none."""
    v = np.asarray(values, float)
    v = v[::max(1, v.size // LIMIT_VALUES)]
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    lo, hi = np.percentile(v, pct)
    span = hi - lo if hi > lo else max(abs(hi), 1.0) * 0.1
    return lo - pad * span, hi + pad * span


def write_pdf(figures: Sequence, path: str | Path, metadata: dict) -> Path:
    """Write figures as the pages of one PDF, atomically.

    Parameters
    ----------
    figures : sequence of matplotlib.figure.Figure
    path : str or Path
    metadata : dict
        PDF document information (Title, Subject, Keywords…); Creator is set to
        ``limbstiff <version>``.

    Returns
    -------
    Path
    """
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    info = {**metadata, "Creator": f"limbstiff {__version__}"}
    with atomic_output(path) as tmp:
        with PdfPages(tmp, metadata=info) as pdf:
            for fig in figures:
                with matplotlib.rc_context(page_fonts(fig)):
                    pdf.savefig(fig)
    return path
