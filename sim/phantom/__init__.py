"""Parametric femoral vessel phantom: specs, seeded subjects and exact geometry queries.

`load_phantom("default")` reads a spec from assets/phantoms, `make_subject(spec, k)` makes the
k-th anatomical variant, and `Phantom(spec)` answers labels, tissue samples, distances and
meshes in the phantom frame (metres; +z out of the skin, +y distal, +x the patient's right).
"""

from sim.labels import ARTERY, LABEL_NAMES, VEIN
from sim.phantom.anatomy import FemoralAnatomy
from sim.phantom.loader import load_phantom, phantom_digest
from sim.phantom.phantom import VESSEL_SEARCH_RADIUS, Phantom, TissueSample
from sim.phantom.spec import BodySpec, Layer, Material, PhantomSpec, Variation, VesselSpec
from sim.phantom.subjects import make_subject

__all__ = [
    "ARTERY",
    "LABEL_NAMES",
    "VEIN",
    "VESSEL_SEARCH_RADIUS",
    "BodySpec",
    "FemoralAnatomy",
    "Layer",
    "Material",
    "Phantom",
    "PhantomSpec",
    "TissueSample",
    "Variation",
    "VesselSpec",
    "load_phantom",
    "make_subject",
    "phantom_digest",
]
