"""The phantom body's shape: skin surface, depth below it, and inside/outside.

A block's skin is its top face (z = 0), so depth is -z. A leg's skin is the cylinder
x^2 + (z + R)^2 = R^2 along y, so depth is R minus the distance from the axis: both are exact
distances along the skin normal, negative in air.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim.phantom.spec import BodySpec

BLOCK, LEG = 0, 1


def body_parameters(body: BodySpec) -> tuple[int, np.ndarray]:
    """Kind code and `(a, b, c)` parameters for the kernels: block (sx, sy, sz), leg (R, L, 0)."""
    if body.kind == "block":
        return BLOCK, np.array(body.size, dtype=np.float64)
    return LEG, np.array([body.radius, body.length, 0.0])


@njit(cache=True)
def depth_below_skin(kind, params, x, y, z):
    """Depth of a point below the skin along its normal (negative in air)."""
    if kind == BLOCK:
        return -z
    return params[0] - math.sqrt(x * x + (z + params[0]) * (z + params[0]))


@njit(cache=True)
def inside_body(kind, params, x, y, z):
    """Whether a point lies in the body (boundary included)."""
    if kind == BLOCK:
        return abs(x) <= 0.5 * params[0] and abs(y) <= 0.5 * params[1] and -params[2] <= z <= 0.0
    radius = params[0]
    return x * x + (z + radius) * (z + radius) <= radius * radius and abs(y) <= 0.5 * params[1]


def skin_height(body: BodySpec, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """z of the skin above (x, y); NaN outside the body's footprint."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    with np.errstate(invalid="ignore"):
        if body.kind == "block":
            inside = (np.abs(x) <= body.size[0] / 2) & (np.abs(y) <= body.size[1] / 2)
            height = np.zeros_like(x)
        else:
            inside = (np.abs(x) <= body.radius) & (np.abs(y) <= body.length / 2)
            height = np.sqrt(body.radius**2 - x**2) - body.radius
    return np.where(inside, height, np.nan)


def skin_normal(body: BodySpec, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Outward unit normal of the skin above (x, y), shape (..., 3); NaN outside the footprint."""
    x = np.asarray(x, dtype=np.float64)
    z = skin_height(body, x, y)
    if body.kind == "block":
        normal = np.stack(np.broadcast_arrays(0.0 * z, 0.0 * z, 1.0 + 0.0 * z), axis=-1)
    else:
        x = np.broadcast_to(x, z.shape)
        normal = np.stack([x, np.zeros_like(z), z + body.radius], axis=-1) / body.radius
    return np.where(np.isnan(z)[..., None], np.nan, normal)
