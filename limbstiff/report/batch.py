"""Batch overview PDF: every trial of a run on a few pages.

Plot pages show, one row per successful trial, the median stiffness, inertia and damping with
their intervals and the informed fraction, sorted and grouped by metadata keys; table pages
list every trial with its status and, for a failed one, why. At most
:data:`TRIALS_PER_PAGE` trials per plot page, so that a run of hundreds stays legible.
"""

from __future__ import annotations

import re
import textwrap
from itertools import groupby
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..provenance import dependencies_text, software
from .common import FONT, MIN_FONT, TEXT_PANEL, footer, new_page, style, text_panel, write_pdf

#: Trials per plot page.
TRIALS_PER_PAGE = 40
#: Text lines per table page.
LINES_PER_PAGE = 54
#: Longest trial label shown (longer ones are cut with "…").
LABEL_CHARS = 30
_PANELS = (("stiffness", 2.2), ("inertia", 1.0), ("damping", 1.0), ("observable_fraction", 0.7))


def _natural(value: Any) -> tuple:
    """Sort key that orders "S2" before "S10" and numbers by value."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return ((0, float(value), ""),)
    return tuple((0, float(c), "") if c.isdigit() else (1, 0.0, c.lower())
                 for c in re.split(r"(\d+)", str(value)) if c)


def group_value(row: Mapping, key: str) -> Any:
    """A row's value of a sort key: from its metadata, else the row itself; None if absent."""
    meta = row.get("metadata") or {}
    value = meta.get(key, row.get(key) if not isinstance(row.get(key), (dict, list)) else None)
    return None if value in (None, "") else value


def order_rows(rows: Sequence[Mapping], sort_by: Sequence[str] | None = None) -> list[Mapping]:
    """Rows sorted by the metadata keys ``sort_by`` (missing values last), then by trial name.

    Parameters
    ----------
    rows : sequence of dict
        ``summary.json`` contents of ok trials, ``{"trial", "status": "failed", "error"}`` of failed ones.
    sort_by : sequence of str, optional
        Metadata keys (for instance ``["subject", "condition"]``).

    Returns
    -------
    list of dict
    """
    keys = list(sort_by or [])

    def key(row):
        parts = []
        for k in keys:
            v = group_value(row, k)
            parts.append((1, ()) if v is None else (0, _natural(v)))
        return tuple(parts) + (_natural(row.get("trial", "")),)

    return sorted(rows, key=key)


def _group_label(row, keys) -> str:
    return " · ".join(f"{k}: {group_value(row, k) if group_value(row, k) is not None else '(none)'}" for k in keys)


def _ok(row) -> bool:
    return row.get("status", "ok") == "ok" and isinstance(row.get("stiffness"), Mapping)


def _value(row, name) -> tuple[float, float, float]:
    """(median, lo, hi) of an interval field, NaN where missing; a fraction as a percentage."""
    v = row.get(name)
    if name == "observable_fraction":
        x = float(v) * 100 if isinstance(v, (int, float)) else np.nan
        return x, x, x
    if not isinstance(v, Mapping):
        return np.nan, np.nan, np.nan
    return tuple(float(v[k]) if isinstance(v.get(k), (int, float)) else np.nan for k in ("median", "lo", "hi"))


def _unit(rows, name) -> str:
    if name == "observable_fraction":
        return "%"
    units = sorted({(r.get("units") or {}).get(name, "") for r in rows} - {""})
    return " or ".join(units) if units else "SI"


def _slots(page_rows, keys):
    """(y, kind, row) for the rows of one plot page: a header slot before each group."""
    out, y = [], 0
    for label, members in groupby(page_rows, key=lambda r: _group_label(r, keys)):
        if keys:
            out.append((y, "group", label))
            y += 1
        for row in members:
            out.append((y, "trial", row))
            y += 1
    return out, y


def _plot_page(page_rows, keys, ci_level, title_lines):
    fig = new_page()
    for k, line in enumerate(title_lines):
        fig.text(0.06, 0.965 - 0.022 * k, line, fontsize=FONT["title"] - 2 if k == 0 else FONT["body"],
                 weight="bold" if k == 0 else "normal", va="top")
    slots, n = _slots(page_rows, keys)
    longest = max(len(_short(r["trial"])) for r in page_rows)
    left = float(np.clip(0.05 + 0.0075 * longest, 0.14, 0.32))
    top = 0.965 - 0.022 * len(title_lines) - 0.035
    height = (top - 0.1) * min(1.0, (n + 1) / (TRIALS_PER_PAGE + 6))
    total = sum(w for _, w in _PANELS)
    gap, x = 0.03, left
    width = 0.97 - left - gap * (len(_PANELS) - 1)
    axes = []
    for name, w in _PANELS:
        ax = fig.add_axes((x, top - height, width * w / total, height), sharey=axes[0] if axes else None)
        x += width * w / total + gap
        axes.append(ax)
        _panel(ax, name, slots, page_rows, ci_level)
    axes[0].set_ylim(n - 0.5, -0.5)
    ticks = [(y, _short(r["trial"])) for y, kind, r in slots if kind == "trial"]
    axes[0].set_yticks([y for y, _ in ticks], [t for _, t in ticks], fontsize=MIN_FONT)
    for ax in axes[1:]:
        ax.tick_params(labelleft=False)
    from matplotlib.ticker import MaxNLocator
    from matplotlib.transforms import blended_transform_factory
    for ax, (name, _) in zip(axes, _PANELS):
        if ax.get_gid() != TEXT_PANEL and ax.get_xscale() == "linear":
            ax.xaxis.set_major_locator(MaxNLocator(nbins=5 if name == "stiffness" else 2, min_n_ticks=2))
        ax.tick_params(axis="x", labeltop=len(page_rows) > 10, top=len(page_rows) > 10)
    heading = blended_transform_factory(fig.transFigure, axes[0].transData)
    for y, kind, label in slots:
        if kind == "group":
            fig.text(0.02, y, label, transform=heading, va="center", fontsize=MIN_FONT, weight="bold")
            for ax in axes:
                ax.axhspan(y - 0.5, y + 0.5, color="0.92", lw=0, zorder=0)
    return fig


def _short(name: str) -> str:
    name = str(name)
    return name if len(name) <= LABEL_CHARS else name[:LABEL_CHARS - 1] + "…"


def _panel(ax, name, slots, page_rows, ci_level):
    label = {"stiffness": "stiffness", "inertia": "inertia", "damping": "damping",
             "observable_fraction": "informed"}[name]
    ys, med, lo, hi = [], [], [], []
    for y, kind, row in slots:
        if kind != "trial":
            continue
        m, a, b = _value(row, name)
        if np.isfinite(m):
            ys.append(y)
            med.append(m)
            lo.append(a if np.isfinite(a) else m)
            hi.append(b if np.isfinite(b) else m)
    ax.grid(True, axis="x")
    ax.grid(False, axis="y")
    ax.tick_params(axis="x", labelsize=MIN_FONT)
    if not ys:
        ax.set_gid(TEXT_PANEL)
        ax.set_xticks([])
        ax.text(0.5, 0.5, "not used\n(direct variant)" if name in ("inertia", "damping") else "no values",
                transform=ax.transAxes, ha="center", va="center", fontsize=MIN_FONT, color="0.4")
        ax.set_xlabel(label)
        return
    med, lo, hi = map(np.asarray, (med, lo, hi))
    if name == "observable_fraction":
        ax.barh(ys, med, height=0.6, color="C2", alpha=0.7)
        ax.set_xlim(0, 100)
    else:
        ax.errorbar(med, ys, xerr=[np.maximum(med - lo, 0), np.maximum(hi - med, 0)], fmt="o", ms=3.5,
                    color="C0" if name == "stiffness" else "C1", capsize=2, lw=1)
        if np.all(lo > 0) and hi.max() / lo.min() > 30:
            ax.set_xscale("log")
    unit = _unit(page_rows, name)
    ax.set_xlabel(f"{label} [{unit}]" + (f"\nmedian, {100 * ci_level:.0f} % interval" if name == "stiffness" else ""),
                  fontsize=MIN_FONT + 1)


def _table_blocks(rows, keys):
    """Per trial, its table lines as (cells, failed?): a failed trial's error wrapped below it."""
    blocks = []
    for i, row in enumerate(rows, start=1):
        ok = _ok(row)
        cells = {"#": str(i), "trial": str(row.get("trial", "?")),
                 "status": str(row.get("verdict") or "done") if ok else str(row.get("status", "failed")),
                 "group": " · ".join(str(group_value(row, k) or "—") for k in keys)}
        if ok:
            m, a, b = _value(row, "stiffness")
            cells["stiffness"] = f"{m:.4g} [{a:.4g}, {b:.4g}]"
            for name in ("inertia", "damping"):
                v = _value(row, name)[0]
                cells[name] = "—" if not np.isfinite(v) else f"{v:.4g}"
            cells["informed"] = f"{_value(row, 'observable_fraction')[0]:.0f} %"
            blocks.append([(cells, False)])
        else:
            error = textwrap.wrap(str(row.get("error") or "no reason given"), _ERROR_CHARS) or [""]
            cells["stiffness"] = error[0]
            blocks.append([(cells, True)] + [({"stiffness": more}, True) for more in error[1:]])
    return blocks


#: Table columns: name, x (figure fraction), alignment, most characters.
_COLUMNS = (("#", 0.06, "right", 4), ("trial", 0.07, "left", LABEL_CHARS), ("status", 0.285, "left", 10),
            ("group", 0.365, "left", 21), ("stiffness", 0.53, "left", 24), ("inertia", 0.70, "left", 11),
            ("damping", 0.80, "left", 11), ("informed", 0.965, "right", 8))
#: Characters of a failed trial's error per line (from the stiffness column to the margin).
_ERROR_CHARS = 56


def _table_pages(rows, keys, units):
    chunks, page = [], []
    for block in _table_blocks(rows, keys):
        block = block[:LINES_PER_PAGE]
        if page and len(page) + len(block) > LINES_PER_PAGE:
            chunks.append(page)
            page = []
        page += block
    chunks.append(page)
    header = [({"#": "#", "trial": "trial", "status": "verdict", "group": " · ".join(keys),
                "stiffness": "stiffness", "inertia": "inertia", "damping": "damping", "informed": "informed"}, None),
              ({"stiffness": f"median [lo, hi], {units['stiffness']}", "inertia": units["inertia"],
                "damping": units["damping"], "informed": "%"}, None)]
    columns = [c for c in _COLUMNS if keys or c[0] != "group"]
    pages = []
    for n, lines in enumerate(chunks):
        fig = new_page("Trials" + (" (continued)" if n else ""))
        y = 0.92
        for k, (cells, failed) in enumerate(header + lines):
            for name, x, align, chars in columns:
                text = cells.get(name)
                if not text:
                    continue
                if failed is None or not (failed and name == "stiffness"):
                    text = text if len(text) <= chars else text[:chars - 1] + "…"
                fig.text(x, y, text, fontsize=MIN_FONT, ha=align, va="top",
                         weight="bold" if failed is None and k == 0 else "normal",
                         color="C3" if failed and name in ("status", "stiffness") else "k")
            y -= 0.0148
        pages.append(fig)
    return pages


def batch_figures(rows: Sequence[Mapping], *, sort_by: Sequence[str] | None = None, ci_level: float = 0.9) -> list:
    """The overview's pages as figures, without writing anything.

    Parameters
    ----------
    rows : sequence of dict
        See :func:`write_batch_overview`.
    sort_by : sequence of str, optional
    ci_level : float
        Level of the intervals (for the labels).

    Returns
    -------
    list of matplotlib.figure.Figure
        Plot pages (none when no trial succeeded), then table pages.
    """
    keys = list(sort_by or [])
    ordered = order_rows(rows, keys)
    ok = [r for r in ordered if _ok(r)]
    n_failed = len(ordered) - len(ok)
    units = {q: _unit(ok, q) for q in ("stiffness", "inertia", "damping")}
    summary = (f"{len(ordered)} trials: {len(ok)} ok, {n_failed} failed"
               + (f" · sorted and grouped by {', '.join(keys)}" if keys else " · sorted by trial name"))
    with style():
        figures = []
        chunks = [ok[i:i + TRIALS_PER_PAGE] for i in range(0, len(ok), TRIALS_PER_PAGE)]
        for k, chunk in enumerate(chunks):
            title = ["Batch overview" + (f" ({k + 1}/{len(chunks)})" if len(chunks) > 1 else ""), summary]
            if len({r.get("units", {}).get("stiffness") for r in ok}) > 1:
                title.append("Trials of different kinds (rotational and translational): mind the units per trial.")
            figures.append(_plot_page(chunk, keys, ci_level, title))
        if not ok:
            fig = new_page("Batch overview")
            text_panel(fig, fig.add_gridspec(1, 1)[0], f"{summary}. No trial succeeded, so there is nothing to plot; "
                                                 "the table lists why each failed.", wrap=80)
            figures.append(fig)
        figures += _table_pages(ordered, keys, units)
        block = software()
        lines = [f"limbstiff {block['version']} · {len(ordered)} trials · intervals at {100 * ci_level:.0f} %",
                 dependencies_text(block)]
        for k, fig in enumerate(figures, start=1):
            footer(fig, lines, k, len(figures))
    return figures


def write_batch_overview(rows: Sequence[Mapping], path: str | Path, *, sort_by: Sequence[str] | None = None,
                         ci_level: float = 0.9) -> Path:
    """Write the overview PDF of a batch run, atomically.

    Parameters
    ----------
    rows : sequence of dict
        One per trial: the ``summary.json`` content of an ok trial (``trial``, ``stiffness``
        ``{median, lo, hi}``, ``inertia``, ``damping``, ``observable_fraction``, ``metadata``,
        ``units``), or ``{"trial": ..., "status": "failed", "error": ...}`` (optionally with
        ``metadata``) for a failed one.
    path : str or Path
    sort_by : sequence of str, optional
        Metadata keys to sort and group the trials by (trials lacking a key sort last);
        default: by trial name, no groups.
    ci_level : float
        Level of the intervals, for the labels.

    Returns
    -------
    Path
    """
    n = len(rows)
    metadata = {"Title": f"limbstiff batch overview: {n} trials",
                "Subject": "Joint stiffness, inertia and damping of every trial of a run",
                "Keywords": "stiffness; batch" + (f"; sorted by {', '.join(sort_by)}" if sort_by else "")}
    with style():
        return write_pdf(batch_figures(rows, sort_by=sort_by, ci_level=ci_level), path, metadata)
