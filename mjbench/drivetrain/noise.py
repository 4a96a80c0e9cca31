"""Seeded Gaussian noise as laws: the same numbers in CPython and in the compiled loop.

A counter-based generator (no hidden state, nothing shared between runs): the j-th 32-bit word of
a stream is ``hash32(j XOR key)``, with ``hash32`` Chris Wellons' *triple32* integer hash (a
bijection of [0, 2³²) with full avalanche), and ``key`` derived from the scenario's ``seed`` and
the stream's number (:func:`stream_key`).  A normal deviate at counter n (the control sample's
index) takes three words: a 53-bit uniform u₁ ∈ (0, 1) from two of them and a 32-bit u₂ from the
third, then Box–Muller, z = √(−2 ln u₁)·cos(2π u₂).

Integers stay in [0, 2⁶³): the 32×32-bit products modulo 2³² are split into 16-bit halves
(:func:`mul32`), so Python's integers and numba's int64 give the same words; the floating-point
part is ``math.log``/``sqrt``/``cos`` on the same IEEE values (tests/test_compiled_drivetrain.py
checks the bits of both and the statistics: mean, deviation, normality, independence of samples
and of streams).  A stream repeats after 2³² words, i.e. 1.4e9 samples (40 h at 10 kHz).
"""
from __future__ import annotations

import math

from ..compiled import law

M32 = 0xFFFFFFFF
#: stream numbers (one per noisy signal: their keys differ, their words are independent)
STREAM_ANGLE, STREAM_SPEED, STREAM_CURRENT, STREAM_CURRENT_LOOP = 1, 2, 3, 4
_TWO_PI = 2.0 * math.pi
_U53 = 1.0 / 9007199254740992.0  # 2^-53
_U32 = 1.0 / 4294967296.0  # 2^-32


@law
def mul32(x, c):
    """(x·c) mod 2³² for x, c in [0, 2³²), without an intermediate above 2⁴⁹."""
    return ((x * (c & 0xFFFF)) + (((x * (c >> 16)) & 0xFFFF) << 16)) & 0xFFFFFFFF


@law
def hash32(x):
    """*triple32* (C. Wellons, "Prospecting for hash functions"): x in [0, 2³²) → [0, 2³²)."""
    x ^= x >> 17
    x = mul32(x, 0xED5AD4BB)
    x ^= x >> 11
    x = mul32(x, 0xAC4C1B51)
    x ^= x >> 15
    x = mul32(x, 0x31848BAB)
    x ^= x >> 14
    return x


@law
def noise_word(key, j):
    """The j-th 32-bit word of the stream ``key`` (j ≥ 0; period 2³²)."""
    return hash32((j & 0xFFFFFFFF) ^ key)


@law
def gauss(key, n):
    """A standard normal deviate, the n-th of the stream ``key`` (n ≥ 0, an int or a whole float)."""
    j = 3 * int(n)
    a = noise_word(key, j)
    b = noise_word(key, j + 1)
    c = noise_word(key, j + 2)
    u1 = ((a >> 5) * 67108864.0 + (b >> 6) + 0.5) * _U53  # (0, 1): log(u1) is finite
    u2 = c * _U32
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(_TWO_PI * u2)


def stream_key(seed: int, stream: int) -> int:
    """The key of one noise stream: every 32-bit part of ``seed`` and the stream's number hashed in."""
    seed = int(seed)
    if seed < 0:
        raise ValueError(f"noise seed {seed}: must be >= 0")
    k = hash32(stream & M32)
    while True:
        k = hash32(k ^ (seed & M32))
        seed >>= 32
        if not seed:
            return k


__all__ = ["gauss", "hash32", "mul32", "noise_word", "stream_key", "STREAM_ANGLE", "STREAM_SPEED",
           "STREAM_CURRENT", "STREAM_CURRENT_LOOP"]
