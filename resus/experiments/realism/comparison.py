"""Two sets measured alike, side by side: the table of `resus realism`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field

from resus.experiments.realism.images import REAL_CREDIT
from resus.experiments.realism.line_orientation import share_between
from resus.experiments.realism.stats import (
    DEPTH_BANDS,
    MEDIAN,
    NINETIETH,
    TENTH,
    RealismSettings,
    RealismStats,
    SpeckleStats,
    VesselShapeStats,
)
from resus.experiments.realism.vessels import ELONGATED_ASPECT, OFF_SIDE_OFFSET

TableRow = tuple[str, Callable[[RealismStats], float | None], int]


def _speckle(get: Callable[[SpeckleStats], float | None]) -> Callable[[RealismStats], float | None]:
    """A table row's getter of a speckle figure: None for a set without tissue windows."""
    return lambda stats: None if stats.speckle is None else get(stats.speckle)


def _shapes(
    get: Callable[[VesselShapeStats], float | None],
) -> Callable[[RealismStats], float | None]:
    """A table row's getter of a vessel-shape figure: None for a set without vessel regions."""
    return lambda stats: None if stats.vessel_shapes is None else get(stats.vessel_shapes)


def _per_vessel(figure: str, quantile: int) -> Callable[[RealismStats], float | None]:
    """A table row's getter of one quantile of a per-region figure: `figure` a contrast
    ("lumen", "lumen_middle", "wall_lateral", "wall_axial" or "round_beside", "_above",
    "_below"), "ellipse_fit" or the per-image "dark_tissue"."""

    def get(shapes: VesselShapeStats) -> float | None:
        quantiles = getattr(shapes, f"{figure}_quantiles")
        return None if quantiles is None else quantiles[quantile]

    return _shapes(get)


def _falloffs(quantile: int) -> Callable[[RealismStats], float | None]:
    """A table row's getter of one quantile of the per-image depth falloff."""
    return lambda s: (
        None if s.depth_falloff_quantiles is None else s.depth_falloff_quantiles[quantile]
    )


def _lines(low: float, high: float) -> Callable[[RealismStats], float | None]:
    """A table row's getter of the share of bright lines `low` to `high` degrees steep."""
    return lambda s: (
        None if s.line_angle_shares is None else share_between(s.line_angle_shares, low, high)
    )


def _band(band: int) -> Callable[[RealismStats], float | None]:
    """A table row's getter of one depth band's tissue grey."""
    return lambda stats: stats.depth_profile[band]


TABLE: tuple[TableRow, ...] = (
    ("mean grey", lambda s: s.mean, 1),
    ("median grey", lambda s: s.median, 1),
    ("tissue mean", lambda s: s.tissue_mean, 1),
    ("lumen mean", lambda s: s.lumen_mean, 1),
    ("lumen/tissue", lambda s: s.lumen_tissue, 3),
    ("5th percentile", lambda s: s.p5, 1),
    ("95th percentile", lambda s: s.p95, 1),
    ("contrast (dB)", lambda s: s.contrast_db, 2),
    ("CNR", lambda s: s.cnr, 3),
    *((f"tissue grey, depth fifth {band + 1}", _band(band), 1) for band in range(DEPTH_BANDS)),
    ("deepest / second fifth", lambda s: s.depth_falloff, 3),
    ("deepest / second fifth, per image median", _falloffs(MEDIAN), 3),
    ("deepest / second fifth, per image 90th percentile", _falloffs(NINETIETH), 3),
    ("speckle std (grey)", _speckle(lambda s: s.std), 2),
    ("speckle std / Rayleigh", _speckle(lambda s: s.std_to_rayleigh), 3),
    ("implied dynamic range (dB)", _speckle(lambda s: s.implied_dynamic_range_db), 1),
    ("window grey SNR, median", _speckle(lambda s: s.snr_quantiles[MEDIAN]), 2),
    ("grain axial FWHM (px)", _speckle(lambda s: s.grain_axial), 2),
    ("grain lateral FWHM (px)", _speckle(lambda s: s.grain_lateral), 2),
    ("grain axial FWHM at the network's input (px)", _speckle(lambda s: s.network_grain_axial), 2),
    (
        "grain lateral FWHM at the network's input (px)",
        _speckle(lambda s: s.network_grain_lateral),
        2,
    ),
    ("bright lines within 10 degrees of across the beam (share)", _lines(0, 10), 3),
    ("bright lines steeper than 45 degrees (share)", _lines(45, 90), 3),
    ("vessel regions", _shapes(lambda s: s.regions), 0),
    ("images showing a vessel (share)", _shapes(lambda s: s.showing_share), 3),
    ("vessel aspect, median", _shapes(lambda s: s.aspect_quantiles[MEDIAN]), 2),
    ("vessel aspect, 90th percentile", _shapes(lambda s: s.aspect_quantiles[NINETIETH]), 2),
    (
        f"vessels over {ELONGATED_ASPECT:g}x longer than wide (share)",
        _shapes(lambda s: s.elongated_share),
        3,
    ),
    (
        "vessel outline / its moment ellipse (IoU), uncut, 10th percentile",
        _per_vessel("ellipse_fit", TENTH),
        3,
    ),
    (
        "vessel outline / its moment ellipse (IoU), uncut, median",
        _per_vessel("ellipse_fit", MEDIAN),
        3,
    ),
    ("vessel area, median (% of image)", _shapes(lambda s: 100 * s.area_quantiles[MEDIAN]), 2),
    ("vessel centre depth, median (share)", _shapes(lambda s: s.depth_quantiles[MEDIAN]), 3),
    (
        "vessel centroid off the middle, per image, median (share of the width)",
        _shapes(lambda s: s.centroid_offset_quantiles[MEDIAN]),
        3,
    ),
    (
        f"images with their vessels {OFF_SIDE_OFFSET:g} or more off the middle (share)",
        _shapes(lambda s: s.off_side_share),
        3,
    ),
    ("vessels cut by the picture's side or bottom (share)", _shapes(lambda s: s.cut_share), 3),
    ("lumen / tissue around it, per vessel, 10th percentile", _per_vessel("lumen", TENTH), 3),
    ("lumen / tissue around it, per vessel, median", _per_vessel("lumen", MEDIAN), 3),
    ("lumen / tissue around it, per vessel, 90th percentile", _per_vessel("lumen", NINETIETH), 3),
    (
        "lumen middle / outer thirds, per vessel, 10th percentile",
        _per_vessel("lumen_middle", TENTH),
        3,
    ),
    ("lumen middle / outer thirds, per vessel, median", _per_vessel("lumen_middle", MEDIAN), 3),
    ("wall / tissue beyond, beside the lumen, median", _per_vessel("wall_lateral", MEDIAN), 2),
    ("wall / tissue beyond, above and below, median", _per_vessel("wall_axial", MEDIAN), 2),
    (
        "wall / tissue beyond, above and below, 90th percentile",
        _per_vessel("wall_axial", NINETIETH),
        2,
    ),
    ("tissue round the lumen / its rows', beside, median", _per_vessel("round_beside", MEDIAN), 2),
    ("tissue round the lumen / its rows', above, median", _per_vessel("round_above", MEDIAN), 2),
    ("tissue round the lumen / its rows', below, median", _per_vessel("round_below", MEDIAN), 2),
    (
        "tissue at the vessels' depth as dark as their lumens, per image, median (share)",
        _per_vessel("dark_tissue", MEDIAN),
        3,
    ),
    (
        "tissue at the vessels' depth as dark as their lumens, per image, 90th percentile",
        _per_vessel("dark_tissue", NINETIETH),
        3,
    ),
)
"""The comparison's rows: label, the figure of a set, decimals shown. The first five are the
issue's table; speckle rows are None for a set without tissue windows."""


@dataclass(frozen=True)
class RealismComparison:
    """A simulated and a real set measured alike."""

    simulated: RealismStats
    real: RealismStats
    settings: RealismSettings = field(default_factory=RealismSettings)

    def table(self) -> list[tuple[str, float | None, float | None]]:
        """(figure, simulated, real) for each row of `TABLE`."""
        return [(label, get(self.simulated), get(self.real)) for label, get, _ in TABLE]

    def to_dict(self) -> dict:
        return {
            "credit": REAL_CREDIT,
            "settings": asdict(self.settings),
            "table": [
                {"figure": label, "simulated": sim, "real": real}
                for label, sim, real in self.table()
            ],
            "simulated": self.simulated.to_dict(),
            "real": self.real.to_dict(),
        }

    def to_markdown(self) -> list[str]:
        """The table as Markdown lines."""
        lines = ["| figure | simulated | real |", "| --- | ---: | ---: |"]
        for (label, sim, real), (_, _, digits) in zip(self.table(), TABLE, strict=True):
            lines.append(f"| {label} | {_shown(sim, digits)} | {_shown(real, digits)} |")
        return lines


def _shown(value: float | None, digits: int) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"
