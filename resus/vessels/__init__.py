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

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
anatomy: AnatomicalFrame VesselPart assign_by_anatomy find_parts
compression: CompressionResult CompressionSettings VesselCall classify_by_compression
figures: save_mesh_views save_needle_slice
map: VesselMap VesselMapSettings build_vessel_map lookup_nearest segment_frames
mesh_distance: MeshDistance
metrics: NeedleTruth SurfaceDistances VesselScore dice needle_truth score_map
needle: NeedlePlan NeedleSettings SkinModel plan_needle
pipeline: MeshSummary VesselJob VesselMapResult map_vessels write_meshes
sections: Section SectionSettings SectionTrack follow_sections
track: CrossSection VesselTrack vessel_track
""",
)
