"""Tissue scatterers fixed in the phantom frame: a hashed random field on a fine 3D lattice.

Every lattice node `(i, j, k)` (spacing `d`, phantom frame) carries a complex scattering
amplitude whose real and imaginary parts are uniform in [-1, 1], drawn from an integer hash of
the node and a seed. Nothing is stored: the field is evaluated where it is needed, by trilinear
interpolation between the eight surrounding nodes, so the same tissue point gives the same
value from any probe pose and the field exists everywhere at no memory cost. The complex
amplitude stands for the many sub-wavelength scatterers inside one node's cell, whose echoes
arrive with random phases; that is what makes the envelope Rayleigh-distributed (fully
developed speckle) even though pixels are about a wavelength apart.

The hash is 32-bit integer arithmetic (a linear combination of the node indices with large odd
multipliers, then the `lowbias32` finaliser), which vectorises and costs under a nanosecond.
The linear step is a bijection on any box smaller than about 1600 nodes a side, so no two nodes
of a phantom share an input.
"""

from __future__ import annotations

import numba
import numpy as np

VALUE_SAFE_FASTMATH = {"nnan", "ninf", "nsz"}
"""The fast-math flags of every imaging kernel: assume no NaN or infinity, ignore the sign of
zero, but never reassociate, contract to fused multiply-adds or approximate functions, since
those let a vectorised loop body and its scalar remainder round differently, and which pixels
fall in which can depend on the arrays' alignment: the same frame could differ by a grey
level from one run to the next."""

_PRIME_I = np.uint32(0x9E3779B1)
_PRIME_J = np.uint32(0x85EBCA77)
_PRIME_K = np.uint32(0xC2B2AE3D)
_MIX_1 = np.uint32(0x7FEB352D)
_MIX_2 = np.uint32(0x846CA68B)
_SHIFT_15 = np.uint32(15)
_SHIFT_16 = np.uint32(16)
_LOW_16 = np.uint32(0xFFFF)
_HALF_16 = np.float32(32768.0)
_TO_UNIT = np.float32(1.0 / 32768.0)

FIELD_COMPONENT_VARIANCE = (2.0 / 3.0) ** 3 / 3.0
"""Variance of one (real or imaginary) component of the field, averaged over positions:
(2/3)^3 from trilinear weights, times 1/3 for a uniform [-1, 1] node value."""


def mix_seed(*keys: int) -> np.uint32:
    """Mix integers (phantom seed, subject, ...) into one 32-bit seed (FNV-1a over the keys)."""
    state = 0x811C9DC5
    for key in keys:
        for byte in int(key).to_bytes(8, "little", signed=True):
            state = ((state ^ byte) * 0x01000193) & 0xFFFFFFFF
    return np.uint32(state)


@numba.njit(inline="always", cache=True)
def mix32(h: np.uint32) -> np.uint32:
    """`lowbias32` finaliser: every input bit affects every output bit."""
    h = np.uint32((h ^ (h >> _SHIFT_16)) * _MIX_1)
    h = np.uint32((h ^ (h >> _SHIFT_15)) * _MIX_2)
    return np.uint32(h ^ (h >> _SHIFT_16))


@numba.njit(inline="always", cache=True)
def unit_pair(h: np.uint32) -> tuple[np.float32, np.float32]:
    """Two values in [-1, 1) from the low and high halves of a hash."""
    real = (np.float32(h & _LOW_16) - _HALF_16) * _TO_UNIT
    imag = (np.float32(h >> _SHIFT_16) - _HALF_16) * _TO_UNIT
    return real, imag


@numba.njit(fastmath=VALUE_SAFE_FASTMATH, cache=True, inline="always")
def field_at(
    u: float | np.float32, v: float | np.float32, w: float | np.float32, seed: np.uint32
) -> tuple[np.float32, np.float32]:
    """The field at one point (lattice units, phantom frame), in hash units (times
    `_TO_UNIT` gives [-1, 1]): trilinear interpolation between the eight nodes around it."""
    one = np.float32(1.0)
    fu = np.floor(u)
    fv = np.floor(v)
    fw = np.floor(w)
    tu = u - fu
    tv = v - fv
    tw = w - fw
    base_i = np.uint32(np.uint32(np.int32(fu)) * _PRIME_I + seed)
    base_j = np.uint32(np.uint32(np.int32(fv)) * _PRIME_J)
    base_k = np.uint32(np.uint32(np.int32(fw)) * _PRIME_K)
    real = np.float32(0.0)
    imag = np.float32(0.0)
    for di in range(2):
        wu = tu if di else one - tu
        hi = np.uint32(base_i + (_PRIME_I if di else np.uint32(0)))
        for dj in range(2):
            wuv = wu * (tv if dj else one - tv)
            hij = np.uint32(hi + base_j + (_PRIME_J if dj else np.uint32(0)))
            for dk in range(2):
                h = mix32(np.uint32(hij + base_k + (_PRIME_K if dk else np.uint32(0))))
                node_weight = wuv * (tw if dk else one - tw)
                real += node_weight * (np.float32(h & _LOW_16) - _HALF_16)
                imag += node_weight * (np.float32(h >> _SHIFT_16) - _HALF_16)
    return real, imag


@numba.njit(fastmath=VALUE_SAFE_FASTMATH, cache=True)
def accumulate_line(
    start: np.ndarray,
    step: np.ndarray,
    weight: float,
    seed: np.uint32,
    out_real: np.ndarray,
    out_imag: np.ndarray,
) -> None:
    """Add `weight` times the field at `len(out_real)` points `start + i * step` (in lattice
    units, phantom frame) to `out_real`, `out_imag`. One straight line of points keeps the
    loop free of branches, so it vectorises."""
    u0 = np.float32(start[0])
    v0 = np.float32(start[1])
    w0 = np.float32(start[2])
    du = np.float32(step[0])
    dv = np.float32(step[1])
    dw = np.float32(step[2])
    scale = np.float32(weight) * _TO_UNIT
    for n in range(out_real.shape[0]):
        real, imag = field_at(
            u0 + np.float32(n) * du, v0 + np.float32(n) * dv, w0 + np.float32(n) * dw, seed
        )
        out_real[n] += scale * real
        out_imag[n] += scale * imag


@numba.njit(fastmath=VALUE_SAFE_FASTMATH, cache=True)
def accumulate_coordinates(
    u: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    weight: float,
    seed: np.uint32,
    out_real: np.ndarray,
    out_imag: np.ndarray,
) -> None:
    """Add `weight` times the field at the points `(u[i], v[i], w[i])` (float32 lattice
    units, phantom frame) to `out_real[i]`, `out_imag[i]`: a scan line of a deformed frame,
    whose pixels no longer lie on a straight line of the tissue. Contiguous coordinates keep
    the loop as vectorisable as `accumulate_line`'s."""
    scale = np.float32(weight) * _TO_UNIT
    for n in range(out_real.shape[0]):
        real, imag = field_at(u[n], v[n], w[n], seed)
        out_real[n] += scale * real
        out_imag[n] += scale * imag
