"""Bitsets of any size for the compiled kernels: active sets of complementarity pairs and switch
keys (bit i: pair i active, switch i on).

A bitset of n bits is an int64 array of :func:`words` words, bit ``i & 63`` of word ``i >> 6``.
The functions are inlined into the kernels (``lcs.jit.inline``); the Python helpers convert
to and from Python integers at the boundary.
"""

from __future__ import annotations

import numpy as np

from .jit import inline


def words(n: int) -> int:
    """Words of a bitset of ``n`` bits (at least one)."""
    return max(1, (int(n) + 63) // 64)


def to_words(value: int, w: int) -> np.ndarray:
    """A non-negative Python integer as a bitset of ``w`` words."""
    out = np.zeros(w, np.int64)
    mask = (1 << 64) - 1
    for i in range(w):
        word = (value >> (64 * i)) & mask
        out[i] = word - (1 << 64) if word >= (1 << 63) else word
    return out


def from_words(arr) -> int:
    """The Python integer of a bitset."""
    value = 0
    for i, word in enumerate(np.asarray(arr, dtype=np.int64).tolist()):
        value |= (word & ((1 << 64) - 1)) << (64 * i)
    return value


@inline
def bit(mask, i):
    """Bit ``i`` (0 or 1)."""
    return (mask[i >> 6] >> (i & 63)) & 1


@inline
def set_bit(mask, i):
    mask[i >> 6] |= np.int64(1) << (i & 63)


@inline
def clear_bit(mask, i):
    mask[i >> 6] &= ~(np.int64(1) << (i & 63))


@inline
def flip_bit(mask, i):
    mask[i >> 6] ^= np.int64(1) << (i & 63)


@inline
def clear_bits(mask):
    for w in range(mask.shape[0]):
        mask[w] = 0


@inline
def copy_bits(src, dst):
    for w in range(src.shape[0]):
        dst[w] = src[w]


@inline
def equal_bits(a, b):
    for w in range(a.shape[0]):
        if a[w] != b[w]:
            return False
    return True


@inline
def any_bits(a):
    for w in range(a.shape[0]):
        if a[w] != 0:
            return True
    return False


@inline
def from_int(value, mask):
    """The bitset of an int64 bitmask (bits 0..62)."""
    clear_bits(mask)
    mask[0] = value


@inline
def row_equals(rows, r, mask):
    """Whether row ``r`` of a stack of bitsets equals ``mask`` (no view: an array view in a
    kernel loop costs reference counting)."""
    for w in range(mask.shape[0]):
        if rows[r, w] != mask[w]:
            return False
    return True


@inline
def copy_row(src, r, dst, q):
    """Row ``r`` of a stack of bitsets into row ``q`` of another."""
    for w in range(src.shape[1]):
        dst[q, w] = src[r, w]
