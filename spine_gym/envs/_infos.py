"""Info dicts of a step built from the step's table rows: SB3's per-env dicts fill themselves on
first use (:class:`RowInfo`), Gymnasium's vector dict is a plain ``dict`` built at once
(:func:`vector_info`).

Every step the env layer hands out info dicts built from the step rows of its table. Building
SB3's list of one dict per environment (13+ keys each) cost about as much Python time as the rest
of the env layer, while SB3's PPO/SAC read only ``terminal_observation``, ``TimeLimit.truncated``,
``episode`` and ``is_success`` of them. A :class:`LazyDict` holds the step's fresh rows and fills
its table keys on the first access that needs them; keys set from outside (``TimeLimit.truncated``,
``terminal_observation``, a wrapper's ``episode``) are read, tested and written without filling it.
Filled, it holds exactly the keys, values and order of the eager dict, and a copy, deep copy or
pickle of it is a plain ``dict``.

Gymnasium's dict of arrays with ``_key`` masks is built eagerly as a plain ``dict``: Gymnasium's
``data_equivalence`` and ``check_environments_match`` compare types strictly, so a ``dict``
subclass differs from ``SyncVectorEnv``'s info however equal its values. :func:`vector_info` builds
it from views of the rows and of one block of masks, with the step's few Python calls precomputed
per table (:func:`vector_info_keys`).
"""

from __future__ import annotations

from collections.abc import Callable
from itertools import chain, repeat
from operator import itemgetter
from typing import NamedTuple

import numpy as np

from ..physics import columns as L

__all__ = [
    "LazyDict",
    "RowInfo",
    "VectorInfoKeys",
    "row_infos",
    "status_text",
    "status_texts",
    "vector_info",
    "vector_info_keys",
]


def status_text(code: int) -> str:
    """``info["status_text"]`` of a step with status ``code`` (from ``layout.STATUS_TEXT``)."""
    return L.STATUS_TEXT.get(int(code), str(int(code)))


def status_texts(status: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``info["status_text"]`` of failed steps: (positions j with ``status[j] != OK``, their
    :func:`status_text` as an object array)."""
    if not status.any():  # L.OK == 0: the common case, no failure
        return _NO_ROWS, _NO_TEXTS
    failed = np.flatnonzero(status != L.OK)
    return failed, np.array([status_text(c) for c in status[failed]], dtype=object)


_NO_ROWS = np.zeros(0, dtype=np.int64)
_NO_TEXTS = np.zeros(0, dtype=object)



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


class VectorInfoKeys(NamedTuple):
    """What :func:`vector_info` needs of a table (:func:`vector_info_keys`)."""

    keys: tuple[str, ...]  # every info key of the table and ``status``, each followed by ``_key``
    values: Callable[[np.ndarray], tuple]  # a block of step rows (n, width) -> the table keys' values
    n_keys: int  # the table's info keys and ``status``


def vector_info_keys(table) -> VectorInfoKeys:
    """The :class:`VectorInfoKeys` of ``table``: its info keys and ``status`` with their ``_key``
    masks, and the getter of each table key's values (views) in a block of step rows."""
    keys = tuple(chain.from_iterable((k, "_" + k) for k in (*table.info_keys, "status")))
    index = table.info_index
    values = itemgetter(*index) if len(index) > 1 else (lambda block: (block[index[0]],))
    return VectorInfoKeys(keys, values, len(index) + 1)


def vector_info(spec: VectorInfoKeys, block: np.ndarray, status: np.ndarray) -> dict:
    """Gymnasium's info dict (a plain ``dict``) of a vector step in which every environment has every
    key: each key's values (views of ``block``, the step rows (n, width), a fresh copy that is not
    written again; ``status`` (n,) itself) and its all-True ``_key`` mask (a view of one fresh
    (keys, n) block), in the order ``SyncVectorEnv`` gives them. No ``status_text``: the caller
    adds it on the rows whose step failed."""
    out = [None] * (2 * spec.n_keys)
    out[0:-2:2] = spec.values(block)
    out[-2] = status
    out[1::2] = np.ones((spec.n_keys, block.shape[0]), dtype=np.bool_)
    return dict(zip(spec.keys, out, strict=True))


def row_infos(table, block: np.ndarray, status: np.ndarray, truncated: list[bool]) -> list[RowInfo]:
    """One :class:`RowInfo` per step row of ``block`` (n, width; a fresh copy that is not written
    again), with the status codes ``status`` (n,) and the n ``TimeLimit.truncated`` flags."""
    return list(map(RowInfo, repeat((table, block, status)), range(block.shape[0]), truncated))
