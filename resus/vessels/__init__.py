"""Stage 5: a sweep's vessel labels to a 3D map of artery and vein, and a needle insertion site.

- `map`: the label images compounded into a vessel map (`VesselMapSettings`, `VesselMap`).
- `anatomy`: the map's connected parts, classed artery or vein by the femoral anatomy.
- `sections`: vessel cross-sections in each frame, followed through the sweep in 3D.
- `compression`: artery or vein by pressing: the vein collapses, the artery stays open and
  pulses; the frames relabelled by it.
- `track`: a vessel's course, cross-section by cross-section along the leg.
- `needle`: the insertion site (skin entry, direction, depth) from the map and the skin.
- `mesh_distance`: exact distance from points to a triangle mesh.
- `metrics`: the map and the needle path scored against the phantom's true geometry.
- `figures`: pictures of the map against the truth and of the needle over a slice.
- `pipeline`: all of it for one sweep, writing meshes, volumes, pictures and vessels.json.
"""

from resus.vessels.anatomy import AnatomicalFrame, VesselPart, assign_by_anatomy, find_parts
from resus.vessels.compression import (
    CompressionResult,
    CompressionSettings,
    VesselCall,
    classify_by_compression,
)
from resus.vessels.figures import save_mesh_views, save_needle_slice
from resus.vessels.map import (
    VesselMap,
    VesselMapSettings,
    build_vessel_map,
    lookup_nearest,
    segment_frames,
)
from resus.vessels.mesh_distance import MeshDistance
from resus.vessels.metrics import (
    NeedleTruth,
    SurfaceDistances,
    VesselScore,
    dice,
    needle_truth,
    score_map,
)
from resus.vessels.needle import NeedlePlan, NeedleSettings, SkinModel, plan_needle
from resus.vessels.pipeline import (
    MeshSummary,
    VesselJob,
    VesselMapResult,
    map_vessels,
    write_meshes,
)
from resus.vessels.sections import Section, SectionSettings, SectionTrack, follow_sections
from resus.vessels.track import CrossSection, VesselTrack, vessel_track

__all__ = [
    "AnatomicalFrame",
    "CompressionResult",
    "CompressionSettings",
    "CrossSection",
    "MeshDistance",
    "MeshSummary",
    "NeedlePlan",
    "NeedleSettings",
    "NeedleTruth",
    "Section",
    "SectionSettings",
    "SectionTrack",
    "SkinModel",
    "SurfaceDistances",
    "VesselCall",
    "VesselJob",
    "VesselMap",
    "VesselMapResult",
    "VesselMapSettings",
    "VesselPart",
    "VesselScore",
    "VesselTrack",
    "assign_by_anatomy",
    "build_vessel_map",
    "classify_by_compression",
    "dice",
    "find_parts",
    "follow_sections",
    "lookup_nearest",
    "map_vessels",
    "needle_truth",
    "plan_needle",
    "save_mesh_views",
    "save_needle_slice",
    "score_map",
    "segment_frames",
    "vessel_track",
    "write_meshes",
]
