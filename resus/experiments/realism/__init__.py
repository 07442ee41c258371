"""How close simulated B-mode images come to real ones: grey levels, contrast and speckle.

Each side of the comparison is an `ImageSet`: 8-bit grey images with a vessel mask each, the
labelled frames of simulated sweeps (artery or vein = vessel) or a folder of real images with
masks (`images/NNNN.png`, `masks/NNNN.png`, 255 = lumen). `measure` turns a set into
`RealismStats`, `compare` puts two side by side (`RealismComparison.table()`), and
`write_realism_report` writes realism.json, realism.md and two figures.

- `images`: the image sets, read from sweeps or a folder, and each image's imaged area.
- `stats`: the settings and the figures of one set, typed.
- `speckle`: grey-level speckle in tissue windows, against the Rayleigh reference, and its grain.
- `vessels`: each vessel cross-section's shape, placement, wall, lumen and surroundings, and the
  tissue beside the vessels as dark as their lumens.
- `line_orientation`: which way the tissue's bright lines run.
- `measurement`: `measure`, one set measured; `compare`, two.
- `comparison`: the table of both sets side by side.
- `report`: realism.json, realism.md, sim_vs_real.png and histograms.png.
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
comparison: TABLE RealismComparison
images: REAL_CREDIT ImageSet imaged_region read_image_folder read_sweep_set
measurement: compare measure
report: HISTOGRAMS_PNG REALISM_JSON REALISM_MD SIM_VS_REAL_PNG write_realism_report
speckle: RAYLEIGH_LOG_STD_DB full_width_half_maximum rayleigh_grey_std
stats: MEDIAN QUANTILES RealismSettings RealismStats SpeckleStats VesselShapeStats
vessels: dark_tissue_share ellipse_fit vessel_contrasts vessel_regions
""",
)
