"""The result protocol every result answers (docs/architecture.md, Layering): one check, shared."""

import json

import pandas as pd


def check_protocol(result, **plot_kwargs):
    """``to_dict()`` is JSON-ready, ``to_frame()`` a non-empty DataFrame, ``plot(ax=…)`` draws on the
    axes given and returns it, ``report()`` is non-empty text. Returns (dict, frame, text)."""
    from matplotlib.figure import Figure
    data = result.to_dict()
    assert isinstance(data, dict) and json.loads(json.dumps(data, allow_nan=False))
    frame = result.to_frame()
    assert isinstance(frame, pd.DataFrame) and len(frame) > 0
    ax = Figure().subplots()
    assert not ax.has_data()
    assert result.plot(ax=ax, **plot_kwargs) is ax and ax.has_data()
    text = result.report()
    assert isinstance(text, str) and text.strip()
    return data, frame, text
