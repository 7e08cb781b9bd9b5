"""Info dicts that fill themselves from the step's table rows on first use (issue 11).

Every step the env layer hands out info dicts built from the step rows of its table: Gymnasium's
dict of arrays with ``_key`` masks (:class:`VectorInfo`) and SB3's list of one dict per
environment (:class:`RowInfo`). Building them (13+ keys, the vector entries as array views, a
mask per key) cost about as much Python time as the rest of the env layer, while training reads
few of them: SB3's PPO/SAC read only ``terminal_observation``, ``TimeLimit.truncated``,
``episode`` and ``is_success`` of the per-env dicts, and a Gymnasium training loop often no info
at all. A :class:`LazyDict` holds the step's fresh rows and fills its table keys on the first
access that needs them; keys set from outside (``TimeLimit.truncated``, ``terminal_observation``,
``final_obs``, a wrapper's ``episode``) are read, tested and written without filling it. Filled,
it holds exactly the keys, values and order of the eager dict, and a copy, deep copy or pickle of
it is a plain ``dict``.
"""

from __future__ import annotations

from itertools import chain, repeat

import numpy as np

from ..physics import layout as L
from .core import status_text

__all__ = ["LazyDict", "RowInfo", "VectorInfo", "row_infos", "vector_info_keys"]


class LazyDict(dict):
    """A ``dict`` whose keys :meth:`_has` are filled from ``src`` by :meth:`_items` on first need.

    Every read of the whole dict (iteration, length, views, comparison, copy, pickle) or of one of
    those keys fills it first; keys set from outside stay after the filled ones.
    """

    __slots__ = ("_src",)

    def __init__(self, src: tuple):
        self._src = src

    def _items(self, src: tuple) -> dict:
        """The filled keys and values, in order."""
        raise NotImplementedError

    def _has(self, src: tuple, key) -> bool:
        """``key`` is one of the filled keys."""
        raise NotImplementedError

    def _fill(self) -> None:
        src = self._src
        if src is None:
            return
        self._src = None
        extras = dict(dict.items(self))
        dict.clear(self)
        dict.update(self, self._items(src))
        dict.update(self, extras)

    def _lazy(self, key) -> bool:
        return self._src is not None and self._has(self._src, key)

    # reads
    def __getitem__(self, key):
        if self._lazy(key):
            self._fill()
        return dict.__getitem__(self, key)

    def get(self, key, default=None):
        if self._lazy(key):
            self._fill()
        return dict.get(self, key, default)

    def __contains__(self, key) -> bool:
        return self._lazy(key) or dict.__contains__(self, key)

    def __iter__(self):
        self._fill()
        return dict.__iter__(self)

    def __reversed__(self):
        self._fill()
        return dict.__reversed__(self)

    def __len__(self) -> int:
        self._fill()
        return dict.__len__(self)

    def keys(self):
        self._fill()
        return dict.keys(self)

    def values(self):
        self._fill()
        return dict.values(self)

    def items(self):
        self._fill()
        return dict.items(self)

    def __repr__(self) -> str:
        self._fill()
        return dict.__repr__(self)

    def __eq__(self, other):
        self._fill()
        if isinstance(other, LazyDict):
            other._fill()
        return dict.__eq__(self, other)

    def __ne__(self, other):
        eq = self.__eq__(other)
        return eq if eq is NotImplemented else not eq

    __hash__ = None

    def copy(self) -> dict:
        self._fill()
        return dict(dict.items(self))

    __copy__ = copy

    def __reduce__(self):
        return dict, (self.copy(),)

    def __or__(self, other):
        return self.copy() | other

    def __ror__(self, other):
        return dict(other) | self.copy()

    # writes: fill first, so that nothing set here is overwritten later
    def __setitem__(self, key, value) -> None:
        if self._lazy(key):
            self._fill()
        dict.__setitem__(self, key, value)

    def __delitem__(self, key) -> None:
        self._fill()
        dict.__delitem__(self, key)

    def __ior__(self, other):
        self._fill()
        dict.update(self, other)
        return self

    def pop(self, *args):
        self._fill()
        return dict.pop(self, *args)

    def popitem(self):
        self._fill()
        return dict.popitem(self)

    def setdefault(self, key, default=None):
        self._fill()
        return dict.setdefault(self, key, default)

    def update(self, *args, **kwargs) -> None:
        self._fill()
        dict.update(self, *args, **kwargs)

    def clear(self) -> None:
        self._src = None
        dict.clear(self)


class RowInfo(LazyDict):
    """One environment's step info as the single env gives it (the table's keys, ``status`` and,
    on a failed step, ``status_text``), plus SB3's ``TimeLimit.truncated`` (set at once).

    Args:
        src: ``(table, block, status)`` of the step: the env's :class:`.table.Table`, the step rows
            (n, width), a fresh copy the filled dict keeps views of, and the status codes (n,).
        j: this environment's row of ``block``.
        truncated: ``TimeLimit.truncated``.
    """

    __slots__ = ("_j",)

    def __init__(self, src: tuple, j: int, truncated: bool):
        self._src = src
        self._j = j
        dict.__setitem__(self, "TimeLimit.truncated", truncated)

    def _items(self, src: tuple) -> dict:
        table, block, status = src
        out = table.row_dict(block[self._j])
        code = int(status[self._j])
        out["status"] = code
        if code != L.OK:
            out["status_text"] = status_text(code)
        return out

    def _has(self, src: tuple, key) -> bool:
        if key in src[0].info_key_set or key == "status":
            return True
        return key == "status_text" and src[2][self._j] != L.OK


class VectorInfo(LazyDict):
    """Gymnasium's info dict of a vector step in which every environment has every key and no
    step failed (no ``status_text``): each key's values (views of the fresh rows) and its all-True
    ``_key`` mask.

    Args:
        src: ``(keys, index, block, status)``: :func:`vector_info_keys` of the env's table, the
            step rows (n, width), a fresh copy, and the status codes (n,).
    """

    __slots__ = ()

    def _items(self, src: tuple) -> dict:
        (keys, _, index), block, status = src[0], src[1], src[2]
        values = [block[ix] for ix in index]
        values.append(status)
        masks = np.ones((len(values), block.shape[0]), dtype=np.bool_)
        return dict(zip(keys, chain.from_iterable(zip(values, masks, strict=True)), strict=True))

    def _has(self, src: tuple, key) -> bool:
        return key in src[0][1]


def vector_info_keys(table) -> tuple[tuple[str, ...], frozenset, tuple]:
    """``(keys, key set, index)`` of a :class:`VectorInfo`: every info key of ``table`` and
    ``status``, each followed by its ``_key`` mask, and the index of each table key's values in a
    block of step rows."""
    keys = tuple(chain.from_iterable((k, "_" + k) for k in (*table.info_keys, "status")))
    return keys, frozenset(keys), table.info_index


def row_infos(table, block: np.ndarray, status: np.ndarray, truncated: list[bool]) -> list[RowInfo]:
    """One :class:`RowInfo` per step row of ``block`` (n, width; a fresh copy that is not written
    again), with the status codes ``status`` (n,) and the n ``TimeLimit.truncated`` flags."""
    return list(map(RowInfo, repeat((table, block, status)), range(block.shape[0]), truncated))
