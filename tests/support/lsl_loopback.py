"""LSL for the tests: loopback only, and helpers that publish in a thread.

:func:`use_loopback` must run before the first pylsl call of the process (liblsl reads its config
once): each LSL test module calls it at import, before ``pytest.importorskip("pylsl")``.
"""

from __future__ import annotations

import os
import threading
import uuid
from pathlib import Path

CONFIG = Path(__file__).with_name("lsl_api.cfg")


def use_loopback() -> None:
    """Point liblsl at ``lsl_api.cfg``: resolution on this machine only, session ``limbstiff-tests``."""
    os.environ["LSLAPICFG"] = str(CONFIG)


def unique_name(prefix: str = "limbstiff-test") -> str:
    """A stream name no other test (or parallel worker) uses."""
    return f"{prefix}-{uuid.uuid4().hex[:12]}"


class Publisher(threading.Thread):
    """:func:`limbstiff.files.lsl_outlet.publish` in a daemon thread; ``result`` is its return value and
    ``error`` what it raised."""

    def __init__(self, *args, **kwargs):
        super().__init__(daemon=True)
        self.stop = kwargs.setdefault("stop", threading.Event())
        self._call = (args, kwargs)
        self.result = None
        self.error = None

    def run(self):
        from limbstiff.files.lsl_outlet import publish
        args, kwargs = self._call
        try:
            self.result = publish(*args, **kwargs)
        except BaseException as exc:       # reported by the test
            self.error = exc


def restarted(values, *, split: int, pause_s: float, **kwargs) -> threading.Thread:
    """Publish ``values[:split]``, close the outlet, wait ``pause_s`` s, then publish the rest
    with a new outlet of the same name, type and ``source_id`` (a sender restarted), in a thread.

    The second outlet's stamps start at its own ``t0`` (a restarted sender's clock goes on);
    ``thread.results`` holds both return values."""
    from limbstiff.files.lsl_outlet import publish
    stop = kwargs.setdefault("stop", threading.Event())

    def run():
        thread.results.append(publish(values[:split], **kwargs))
        if not stop.wait(pause_s):
            second = dict(kwargs, wait_consumer_s=0.0)
            thread.results.append(publish(values[split:], **second))

    thread = threading.Thread(target=run, daemon=True)
    thread.results = []
    thread.stop = stop
    return thread
