"""One process-wide LRU cache of decoded videos, bounded in bytes and thread-safe.

Every :class:`~dcs_torchrl.videos.VideoSource` decodes through it, keyed by
``(source.cache_key, video name, size)``: a video is decoded once per process and the
same read-only array is shared by every episode and every env of the process. The
bound defaults to 3 GiB (the 60 DAVIS 2017 training videos take ~0.8 GiB at 256x256);
set it with :func:`set_cache_limit` or the environment variable
``DCS_FRAME_CACHE_BYTES`` (a number of bytes, or with a binary suffix: ``512M``, ``3G``).
"""
from __future__ import annotations

import os
import re
import threading
import warnings
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import NamedTuple

import numpy as np

ENV_VAR = "DCS_FRAME_CACHE_BYTES"
DEFAULT_LIMIT = 3 * 2**30
_UNITS = {"": 1, "k": 2**10, "m": 2**20, "g": 2**30, "t": 2**40}
_SIZE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([kmgt]?)(?:i?b)?\s*$", re.IGNORECASE)


class CacheInfo(NamedTuple):
    """Counters of the frame cache (see :func:`cache_info`)."""

    entries: int  # videos held
    bytes: int  # bytes held
    hits: int  # lookups answered from the cache
    misses: int  # lookups that were not
    decodes: int  # videos actually decoded (or generated)
    limit: int  # the bound in bytes


def parse_size(value: int | str, what: str = ENV_VAR) -> int:
    """A number of bytes from an int or a string such as ``"3G"``, ``"512MiB"``, ``"100000"``.

    Examples:
        >>> parse_size("1.5G")
        1610612736
    """
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        size = int(value)
    else:
        match = _SIZE.match(str(value))
        if match is None:
            raise ValueError(
                f"{what}={value!r} is not a size: use a number of bytes such as 3221225472, "
                "or one with a binary suffix such as 512M or 3G."
            )
        size = int(float(match.group(1)) * _UNITS[match.group(2).lower()])
    if size < 0:
        raise ValueError(f"{what} must be >= 0 bytes (0 disables the cache), got {value!r}.")
    return size


def default_limit() -> int:
    """The bound from ``DCS_FRAME_CACHE_BYTES`` if set, else 3 GiB."""
    value = os.environ.get(ENV_VAR, "").strip()
    return parse_size(value) if value else DEFAULT_LIMIT


def _mib(nbytes: int) -> str:
    return f"{nbytes / 2**20:.1f} MiB"


class _Loading:
    """A decode in progress; other threads asking for the same key wait for it."""

    def __init__(self):
        self.done = threading.Event()
        self.value: np.ndarray | None = None


class FrameCache:
    """An LRU map ``key -> read-only uint8 array``, bounded by the sum of ``nbytes``.

    Concurrent requests for one key decode it once: the first caller decodes, the
    others wait for its result. A video larger than the whole bound is returned but not
    kept (with a warning saying how to raise the bound).

    Args:
        limit (int, optional): bound in bytes; ``None`` reads ``DCS_FRAME_CACHE_BYTES``
            (default 3 GiB) at first use.
    """

    def __init__(self, limit: int | None = None):
        self._limit = None if limit is None else parse_size(limit, "limit")
        self._entries: OrderedDict[Hashable, np.ndarray] = OrderedDict()
        self._loading: dict[Hashable, _Loading] = {}
        self._lock = threading.Lock()
        self._bytes = self._hits = self._misses = self._decodes = 0

    @property
    def limit(self) -> int:
        if self._limit is None:
            self._limit = default_limit()
        return self._limit

    def get(self, key: Hashable, decode: Callable[[], np.ndarray]) -> np.ndarray:
        """The array cached under ``key``, from ``decode()`` (made read-only) on a miss."""
        while True:
            with self._lock:
                if key in self._entries:
                    self._entries.move_to_end(key)
                    self._hits += 1
                    return self._entries[key]
                self._misses += 1
                loading = self._loading.get(key)
                owner = loading is None
                if owner:
                    loading = self._loading[key] = _Loading()
            if owner:
                return self._decode(key, decode, loading)
            loading.done.wait()
            if loading.value is not None:  # decoded by another thread (kept or too large)
                return loading.value
            # the other thread failed: try again, and raise its error from here

    def _decode(self, key: Hashable, decode: Callable[[], np.ndarray], loading: _Loading) -> np.ndarray:
        try:
            value = decode()
            if not (isinstance(value, np.ndarray) and value.dtype == np.uint8):
                raise TypeError(f"a video decoder returned {type(value).__name__} for {key!r}, not a uint8 array.")
            value.flags.writeable = False
            with self._lock:
                self._decodes += 1
                if value.nbytes <= self.limit:
                    self._entries[key] = value
                    self._bytes += value.nbytes
                    self._evict()
                    kept = True
                else:
                    kept = False
            if not kept:
                name, size = (key[1], key[2]) if isinstance(key, tuple) and len(key) == 3 else (key, "?")
                warnings.warn(
                    f"video {name!r} at {size}x{size} takes {_mib(value.nbytes)}, more than the whole frame "
                    f"cache bound ({_mib(self.limit)}), so it is not kept and will be decoded again at every "
                    f"use: raise the bound with dcs_torchrl.videos.set_cache_limit(...) or {ENV_VAR}.",
                    stacklevel=4,
                )
            loading.value = value
            return value
        finally:
            with self._lock:
                del self._loading[key]
            loading.done.set()

    def _evict(self) -> None:
        while self._bytes > self.limit and self._entries:
            _, old = self._entries.popitem(last=False)
            self._bytes -= old.nbytes

    def set_limit(self, limit: int | str | None) -> int:
        """Sets the bound (``None``: back to the default), evicts to it, returns the old one."""
        new = default_limit() if limit is None else parse_size(limit, "limit")
        with self._lock:
            old, self._limit = self.limit, new
            self._evict()
        return old

    def discard(self, source_key: Hashable) -> None:
        """Drops every entry of one source (keys ``(source_key, name, size)``)."""
        with self._lock:
            for key in [k for k in self._entries if k[0] == source_key]:
                self._bytes -= self._entries.pop(key).nbytes

    def clear(self) -> None:
        """Drops every entry and zeroes the counters."""
        with self._lock:
            self._entries.clear()
            self._bytes = self._hits = self._misses = self._decodes = 0

    def info(self) -> CacheInfo:
        """Current counters."""
        with self._lock:
            return CacheInfo(len(self._entries), self._bytes, self._hits, self._misses, self._decodes, self.limit)


FRAME_CACHE = FrameCache()


def cache_info() -> CacheInfo:
    """Counters of the process-wide frame cache: entries, bytes, hits, misses, decodes, limit.

    Examples:
        >>> from dcs_torchrl.videos import cache_info
        >>> cache_info().limit >= 0
        True
    """
    return FRAME_CACHE.info()


def set_cache_limit(limit: int | str | None) -> int:
    """Bounds the process-wide frame cache, evicting least recently used videos to fit.

    Args:
        limit (int or str, optional): bytes (``3 * 2**30``, ``"3G"``); 0 disables caching;
            ``None`` restores ``DCS_FRAME_CACHE_BYTES`` or the 3 GiB default.

    Returns:
        the previous bound in bytes, so it can be restored.

    Examples:
        >>> from dcs_torchrl.videos import set_cache_limit
        >>> old = set_cache_limit("1G")
        >>> _ = set_cache_limit(old)
    """
    return FRAME_CACHE.set_limit(limit)


def clear_cache() -> None:
    """Empties the process-wide frame cache and zeroes its counters."""
    FRAME_CACHE.clear()
