"""Keep freed memory in the process: the allocator setting for training on a CPU.

PyTorch on CPU allocates every activation and gradient with ``malloc`` and frees it at the end
of the update. With glibc's defaults, blocks above the mmap threshold (at most 32 MB; a batch of
pixel observations makes larger activations) are ``mmap``-ed and ``munmap``-ed every time, and
freed heap tops are trimmed: every update page-faults its whole working set back in, and the
kernel zeroes every page (what that costs: docs/notes/performance_log.md, "The update's memory
allocator"; ``benchmarks/update_speed.py --allocators`` compares the settings).

:func:`retain_freed_memory` does what preloading jemalloc (page decay off) does, without another allocator: it calls
glibc's ``mallopt`` to serve large blocks from the heap (``M_MMAP_MAX = 0``) and never trim it
(``M_TRIM_THRESHOLD`` huge), so freed buffers are reused by the next update. The price is that
the process keeps its peak memory (RSS never shrinks). It changes allocations made after the
call, process-wide; call it once at the start of training.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import platform

__all__ = ["retain_freed_memory"]

_M_TRIM_THRESHOLD = -1  # glibc malloc.h
_M_MMAP_MAX = -4
_NEVER = 2**31 - 1  # mallopt takes an int: ~2 GB of free heap top before trimming


def retain_freed_memory() -> bool:
    """Tells glibc's malloc to keep freed memory for reuse; returns whether it was applied.

    A no-op returning ``False`` where the C library is not glibc (macOS, musl, Windows) or under
    another preloaded allocator that ignores ``mallopt`` (jemalloc already retains memory with
    ``MALLOC_CONF=dirty_decay_ms:-1,muzzy_decay_ms:-1``).

    Examples:
        >>> retain_freed_memory() in (True, False)
        True
    """
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return False
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    mallopt = getattr(libc, "mallopt", None)
    if mallopt is None:
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_MAX, 0)) and bool(mallopt(_M_TRIM_THRESHOLD, _NEVER))
