"""Memory addresses as pointers in compiled (numba) code: how the batch reaches arrays numpy does not hold.

A batch's worlds each keep their state in their own MuJoCo ``MjData``; a video clip lives in the frame
cache. Compiled loops over the worlds read them where they lie: each array's address, taken once
(:func:`address`), passed in as an integer and made a typed pointer (:data:`float64_at`, :data:`uint8_at`,
:data:`int32_at`, :data:`void_at`), viewed with ``numba.carray``. The caller keeps the arrays alive.
"""
from __future__ import annotations

import numpy as np
from numba import types
from numba.extending import intrinsic

__all__ = ["address", "float64_at", "int32_at", "uint8_at", "void_at"]


def address(array: np.ndarray, dtype=None) -> int:
    """The address of ``array``'s first element; refuses an array that is not C-contiguous (or not of ``dtype``)."""
    if not array.flags.c_contiguous or (dtype is not None and array.dtype != np.dtype(dtype)):
        raise TypeError(f"expected a C-contiguous {np.dtype(dtype) if dtype else ''} array, got {array.dtype} "
                        f"(C-contiguous: {array.flags.c_contiguous})")
    return array.__array_interface__["data"][0]


def _pointer_to(pointee):
    """An intrinsic making an address (an integer) a pointer to ``pointee`` (``None``: ``void*``)."""
    pointer = types.voidptr if pointee is None else types.CPointer(pointee)

    def typer(typingctx, value):
        if isinstance(value, types.Integer):
            return pointer(value), lambda context, builder, signature, args: builder.inttoptr(
                args[0], context.get_value_type(pointer))
        return None

    return intrinsic(typer)


void_at = _pointer_to(None)
float64_at = _pointer_to(types.float64)
int32_at = _pointer_to(types.int32)
uint8_at = _pointer_to(types.uint8)
