"""A read-only, picklable mapping for the fields of frozen dataclasses.

``types.MappingProxyType`` cannot be pickled, and results and settings cross process
boundaries in parallel batches.
"""

from __future__ import annotations


class FrozenDict(dict):
    """A ``dict`` whose contents cannot be changed after construction."""

    def _read_only(self, *args, **kwargs):
        raise TypeError("this mapping is read-only")

    __setitem__ = __delitem__ = _read_only
    clear = pop = popitem = setdefault = update = _read_only
    __ior__ = _read_only

    def __reduce__(self):
        return (FrozenDict, (dict(self),))

    def __repr__(self):
        return f"FrozenDict({dict.__repr__(self)})"
