"""Vessel cross-sections in each frame of a sweep, followed from frame to frame.

A cross-section is a connected component of a frame's vessel labels (of each class apart, or of
both together when the classes are merged), at least `min_area` large. Its centre and major
axis are placed in the world through the frame's pose, so a section is followed by where it is
in 3D, not only in the image: the probe indents the tissue while it presses, which moves every
vessel up the image, while the vessel itself stays where it is.

Sections of consecutive frames are matched by the assignment of least total distance between
centres (Hungarian), at most `link_distance` apart. A component left over whose centre lies
within `link_distance` of a track's previous section (of its major axis, a segment through its
centre) is a piece of that vessel: a vein pressed nearly flat is a sliver a few pixels thick,
which the pixel grid breaks up; the pieces are joined into the track's section of the frame. A
vessel that vanishes (a vein pressed flat) keeps its track for up to `max_gap` seconds, so that
it is the same track when it opens again; its area in the frames between is zero.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.optimize import linear_sum_assignment

from resus.errors import ResusError
from resus.sweep.model import pixel_spacing, pixels_to_world


@dataclass(frozen=True)
class SectionSettings:
    """How cross-sections are found and followed."""

    merge_classes: bool = False
    """Treat artery and vein as one vessel class: components of every vessel pixel together
    (a segmentation that does not tell them apart, or one not to be trusted to)."""
    min_area: float = 1.0e-6
    """Components smaller than this are specks, not cross-sections (m^2; 1 mm^2)."""
    link_distance: float = 4.0e-3
    """Farthest a section's centre may lie from its track's last one, or a piece's centre from
    the last one's major axis (m): well under the femoral artery-vein distance (9-19 mm
    between centres in the phantoms' subjects)."""
    max_gap: float = 8.0
    """Longest time a track waits for its vessel to appear again (s): a vein stays shut
    through a press's rise, hold and fall."""

    def __post_init__(self) -> None:
        for name in ("min_area", "link_distance", "max_gap"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ResusError(f"SectionSettings.{name} must be positive, got {value}")


@dataclass(frozen=True)
class Section:
    """One vessel cross-section in one frame."""

    frame: int
    label: int
    """The labels' class of its pixels (the larger one if merged)."""
    pixels: np.ndarray
    """Flat indices of its pixels in the frame."""
    area: float
    """m^2."""
    centre: np.ndarray
    """World position of its centroid (m)."""
    roundness: float
    """Ratio of its minor to its major axis (1 for a circle), from its second moments."""
    axis: np.ndarray
    """World unit vector of its major axis."""
    half_length: float
    """Half the length of its major axis (m; an ellipse's semi-major axis)."""

    def distance_to(self, point: np.ndarray) -> float:
        """Distance (m) from a world point to the major axis (the segment through the centre)."""
        offset = point - self.centre
        along = float(np.clip(offset @ self.axis, -self.half_length, self.half_length))
        return float(np.linalg.norm(offset - along * self.axis))

    def joined(self, piece: Section) -> Section:
        """This section and `piece` (of the same vessel, in the same frame) as one: the axis
        runs through both centres and spans both, the roundness is the flatter one's."""
        area = self.area + piece.area
        centre = (self.area * self.centre + piece.area * piece.centre) / area
        axis = piece.centre - self.centre
        axis = axis / np.linalg.norm(axis) if np.linalg.norm(axis) > 0 else self.axis
        ends = [s.centre + sign * s.half_length * s.axis for s in (self, piece) for sign in (-1, 1)]
        half_length = max(abs(float((end - centre) @ axis)) for end in ends)
        return dataclasses.replace(
            self, pixels=np.concatenate([self.pixels, piece.pixels]), area=area, centre=centre,
            roundness=min(self.roundness, piece.roundness), axis=axis, half_length=half_length,
        )  # fmt: skip


def frame_sections(
    label: np.ndarray,
    frame: int,
    pose: np.ndarray,
    image_to_probe: np.ndarray,
    settings: SectionSettings,
) -> list[Section]:
    """The cross-sections of one (H, W) label image taken at `pose`."""
    col_size, row_size = pixel_spacing(image_to_probe)
    image_to_base = pose @ image_to_probe
    directions = image_to_base[:3, :2] / np.array([col_size, row_size])
    values = [None] if settings.merge_classes else np.unique(label[label > 0])
    sections = []
    for value in values:
        components, count = ndimage.label(label > 0 if value is None else label == value)
        for component in range(1, count + 1):
            rows, cols = np.nonzero(components == component)
            area = len(rows) * col_size * row_size
            if area < settings.min_area:
                continue
            points = np.stack([cols * col_size, rows * row_size])
            spread, vectors = np.linalg.eigh(np.cov(points) + 1e-18 * np.eye(2))
            sections.append(
                Section(
                    frame=frame,
                    label=int(np.bincount(label[rows, cols]).argmax()),
                    pixels=np.ravel_multi_index((rows, cols), label.shape).astype(np.int64),
                    area=area,
                    centre=pixels_to_world(pose, image_to_probe, cols.mean(), rows.mean()),
                    roundness=float(np.sqrt(spread[0] / spread[1])),
                    axis=directions @ vectors[:, 1],
                    half_length=2.0 * float(np.sqrt(spread[1])),
                )
            )
    return sections


@dataclass
class SectionTrack:
    """One vessel followed through the sweep: its section in each frame it was seen in."""

    sections: list[Section]
    """In frame order."""

    @property
    def frames(self) -> np.ndarray:
        """(M,) frames it was seen in."""
        return np.array([section.frame for section in self.sections])

    @property
    def span(self) -> np.ndarray:
        """Every frame from its first to its last sighting."""
        return np.arange(self.sections[0].frame, self.sections[-1].frame + 1)

    def areas(self) -> np.ndarray:
        """Area (m^2) in every frame of `span`: zero where the vessel was not seen."""
        areas = np.zeros(len(self.span))
        areas[self.frames - self.span[0]] = [section.area for section in self.sections]
        return areas

    @property
    def centre(self) -> np.ndarray:
        """Mean world position of its sections (m)."""
        return np.mean([section.centre for section in self.sections], axis=0)


def follow_sections(
    sections: list[list[Section]], timestamps: np.ndarray, settings: SectionSettings
) -> list[SectionTrack]:
    """Tracks of the per-frame `sections` (a list per frame), in order of first sighting."""
    tracks: list[SectionTrack] = []
    open_tracks: list[SectionTrack] = []
    for frame, found in enumerate(sections):
        now = timestamps[frame]
        open_tracks = [
            track
            for track in open_tracks
            if now - timestamps[track.sections[-1].frame] <= settings.max_gap
        ]
        previous = [track.sections[-1] for track in open_tracks]
        matched: set[int] = set()
        if open_tracks and found:
            last = np.array([section.centre for section in previous])
            here = np.array([section.centre for section in found])
            distance = np.linalg.norm(last[:, None] - here[None], axis=2)
            for t, s in zip(*linear_sum_assignment(distance), strict=True):
                if distance[t, s] <= settings.link_distance:
                    open_tracks[t].sections.append(found[s])
                    matched.add(int(s))
        for s, section in enumerate(found):
            if s in matched:
                continue
            owner = _broken_from(section, previous, settings)
            if owner is None:
                track = SectionTrack([section])
                tracks.append(track)
                open_tracks.append(track)
                previous.append(section)
                continue
            sections_of = open_tracks[owner].sections
            if sections_of[-1].frame == frame:
                sections_of[-1] = sections_of[-1].joined(section)
            else:
                sections_of.append(section)
    return tracks


def _broken_from(piece: Section, previous: list[Section], settings: SectionSettings) -> int | None:
    """Index of the previous section `piece` lies on (within `link_distance` of its major
    axis, of its class unless merged; the nearest of several), or None."""
    distances = [
        section.distance_to(piece.centre)
        if settings.merge_classes or section.label == piece.label
        else np.inf
        for section in previous
    ]
    if not distances or min(distances) > settings.link_distance:
        return None
    return int(np.argmin(distances))
