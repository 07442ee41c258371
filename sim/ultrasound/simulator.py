"""Synthetic B-mode frames of a vessel phantom seen by a linear probe at a given pose.

One `render` call: map the pixel grid into the phantom, query the phantom once for every pixel
centre (tissue, vessel surface, label), find which transducer elements touch the skin, then run
the two fused kernels of `sim.ultrasound.echo`, each line's echoes scaled by the coupled share
of its active aperture (`sim.ultrasound.beam.aperture_coupling`). Everything is deterministic:
the speckle comes from scatterers fixed in the phantom frame (seeded by the phantom's seed and
subject) and the electronic noise from a hash of the pose, so a pose always gives the same
frame.

Labels describe what the image shows: the phantom's label at each pixel centre, and 0 where
the image is black because the column has no skin contact or the pixel lies in air.

A phantom with `mechanics` deforms under the probe when `render` is given the frame's
`TissueLoad` (contact force and time): the pixel centres are mapped back to the undeformed
tissue they show (`sim.ultrasound.deformation`) before the phantom and the scatterers are
read, so labels stay exact; without a load, or for a rigid phantom, every image is the rigid
world's, bit for bit as before.
"""

from __future__ import annotations

import math
import zlib
from typing import overload

import numpy as np

from sim.phantom import Phantom, TissueSample
from sim.transforms import is_rigid
from sim.ultrasound.beam import aperture_coupling, axial_pulse, elevation_profile, lateral_beam
from sim.ultrasound.compounding import accumulate_steered, compound_lines, steering_angles
from sim.ultrasound.deformation import (
    FrameDeformation,
    ProbeDeformation,
    TissueLoad,
    column_reach,
    undeform_points,
)
from sim.ultrasound.echo import (
    form_image,
    grid_points,
    lateral_clutter,
    scan_lines,
    smooth_lines,
    transpose_pair,
)
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.scatterers import FIELD_COMPONENT_VARIANCE, mix_seed
from sim.ultrasound.settings import UltrasoundSettings

NOISE_COMPONENT_RMS = 1.0 / math.sqrt(3.0)
"""RMS of a uniform [-1, 1] noise component (the hash gives uniform values)."""
TEXTURE_KEY = 0x7E57
"""Mixed into the speckle seed for the texture field's seed, so the two are independent."""
WALL_SEARCH_PAD = 1.0e-6
"""How far past the thickest vessel wall (m) a frame asks the phantom for the nearest vessel
surface: the image needs that surface only inside the wall band (the wall's echo and the
angle of its specular steps), and the pad keeps a pixel exactly on the band's outer edge."""
METRES_PER_CM = 0.01
HZ_PER_MHZ = 1.0e6


@overload
def db_to_amplitude(db: np.ndarray) -> np.ndarray: ...


@overload
def db_to_amplitude(db: float) -> np.float64: ...


def db_to_amplitude(db: np.ndarray | float) -> np.ndarray | np.float64:
    """Amplitude ratio of a level in decibels (a numpy scalar for a scalar level)."""
    return 10.0 ** (np.asarray(db) / 20.0)


def gaussian_taps(sigma: float) -> np.ndarray:
    """A unit-sum Gaussian kernel of standard deviation `sigma` (pixels), +-3 sigma wide; the
    identity (one tap) for sigma 0."""
    if sigma == 0:
        return np.ones(1, dtype=np.float32)
    half = max(1, math.ceil(3.0 * sigma))
    taps = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma) ** 2)
    return (taps / taps.sum()).astype(np.float32)


class UltrasoundSimulator:
    """Renders B-mode frames and exact label images of `phantom` for probe poses."""

    def __init__(
        self,
        phantom: Phantom,
        probe: LinearProbe | None = None,
        settings: UltrasoundSettings | None = None,
    ) -> None:
        self.phantom = phantom
        self.probe = probe = probe or LinearProbe()
        self.settings = settings = settings or UltrasoundSettings()
        spec = phantom.spec
        materials = (*phantom.materials, spec.wall)
        frequency_mhz = probe.centre_frequency / HZ_PER_MHZ
        row_cm = probe.pixel_height / METRES_PER_CM
        speckle_scale = 1.0 / math.sqrt(2.0 * FIELD_COMPONENT_VARIANCE)
        self._echogenicity = np.array(
            [m.echogenicity * speckle_scale for m in materials], dtype=np.float32
        )
        self._round_trip_step = np.array(
            [
                db_to_amplitude(-2.0 * m.attenuation_db_cm_mhz * frequency_mhz * row_cm)
                for m in materials
            ],
            dtype=np.float32,
        )
        self._impedance = np.array([m.impedance_mrayl for m in materials], dtype=np.float32)
        self._texture_variation = np.array(
            [m.texture_variation for m in materials], dtype=np.float32
        )
        self._texture_ridges = np.array(
            [m.texture_ridges * speckle_scale for m in materials], dtype=np.float32
        )
        self._has_texture = any(m.textured for m in materials)
        self._texture_inverse_scale = 1.0 / np.array(spec.texture_scale, dtype=np.float64)
        self._wall_thickness = np.array([v.wall_thickness for v in spec.vessels], dtype=np.float64)
        if len(self._wall_thickness) == 0:
            self._wall_thickness = np.zeros(1)
        self._vessel_search_radius = float(self._wall_thickness.max()) + WALL_SEARCH_PAD
        self._pulse = axial_pulse(probe, settings).astype(np.complex64)
        self._lateral = lateral_beam(probe, settings)
        offsets, weights = elevation_profile(probe, settings)
        self._elevation_offsets = offsets
        self._elevation_weights = weights.astype(np.float32)
        depth_cm = (np.arange(probe.rows) + 0.5) * row_cm
        if settings.tgc_attenuation is None:
            one_way = spec.attenuation_below_skin(depth_cm * METRES_PER_CM)
        else:
            one_way = settings.tgc_attenuation * depth_cm
        tgc_db = 2.0 * frequency_mhz * one_way
        if settings.tgc_sliders_db:
            sliders = np.asarray(settings.tgc_sliders_db, dtype=np.float64)
            tgc_db = tgc_db + np.interp(
                depth_cm, np.linspace(depth_cm[0], depth_cm[-1], len(sliders)), sliders
            )
        self._tgc = db_to_amplitude(tgc_db).astype(np.float32)
        self._seed = mix_seed(spec.seed, -1 if spec.subject is None else spec.subject)
        self._texture_seed = mix_seed(int(self._seed), TEXTURE_KEY)
        noise_rms = spec.noise_level * db_to_amplitude(settings.electronic_noise_db) / self._tgc[-1]
        self._noise_amplitude = noise_rms / (NOISE_COMPONENT_RMS * math.sqrt(2.0))
        self._specular_exponent = math.log(0.5) / math.log(math.cos(settings.specular_angle))
        self._grey_per_log2 = 255.0 / settings.dynamic_range_db * 10.0 * math.log10(2.0)
        self._grey_offset = 255.0 * settings.gain_db / settings.dynamic_range_db
        levels = np.arange(256) / 255.0
        self._grey_map = np.round(255.0 * levels**settings.grey_gamma).astype(np.uint8)
        self._clutter_power = (
            0.0 if settings.clutter_db is None else float(10.0 ** (settings.clutter_db / 10.0))
        )
        across = settings.speckle_smoothing
        along = (
            across if settings.speckle_smoothing_axial is None else settings.speckle_smoothing_axial
        )
        self._smoothing = (
            (gaussian_taps(along / probe.pixel_height), gaussian_taps(across / probe.pixel_width))
            if along or across
            else None
        )
        self._aperture_half_cols = max(1, round(settings.active_aperture / probe.pixel_width / 2))
        self._clutter = np.zeros(probe.cols * probe.rows, dtype=np.float32)
        self._clutter_sums = np.empty((probe.cols + 1, probe.rows), dtype=np.float32)
        self._element_x = probe.column_x()
        lost_first, lost_last = (round(share * probe.cols) for share in settings.lost_coupling)
        self._coupled = np.ones(probe.cols, dtype=bool)
        self._coupled[:lost_first] = False
        self._coupled[probe.cols - lost_last :] = False
        count = probe.cols * probe.rows
        self._points = np.empty((count, 3))
        self._echo_real = np.empty((probe.cols, probe.rows), dtype=np.float32)
        self._echo_imag = np.empty((probe.cols, probe.rows), dtype=np.float32)
        self._image_lines = np.empty((probe.cols, probe.rows), dtype=np.uint8)
        self._smoothed_lines = np.empty_like(self._image_lines)
        self._along = np.empty((probe.cols, probe.rows), dtype=np.float32)
        self._along_weight = np.empty_like(self._along)
        self._label_lines = np.empty((probe.cols, probe.rows), dtype=np.uint8)
        self._image_to_probe = probe.image_to_probe()
        self._sample = TissueSample.empty(count)
        self._steering = steering_angles(settings.compound_frames, settings.compound_angle)
        self._compound_total = np.zeros((probe.cols, probe.rows), dtype=np.float32)
        self._compound_count = np.zeros_like(self._compound_total)
        self.deformation = None if spec.mechanics is None else ProbeDeformation(phantom, probe)
        self.last_deformation: FrameDeformation | None = None
        """The deformation of the last frame rendered deformed (None: rigid)."""

    def contact(
        self, probe_to_phantom: np.ndarray, deformation: FrameDeformation | None = None
    ) -> np.ndarray:
        """(cols,) bool: whether each column's transducer element touches the skin (gel gap
        within `contact_tolerance`, measured along the phantom's z; less the skin drawn up to
        the face by `deformation`) and has not lost its coupling (`lost_coupling`)."""
        elements = probe_to_phantom[:3, 0:1] * self._element_x + probe_to_phantom[:3, 3:4]
        with np.errstate(invalid="ignore"):
            gap = elements[2] - self.phantom.skin_height(elements[0], elements[1])
            if deformation is not None:
                gap += np.minimum(deformation.column_indentation, 0.0)
            return (gap <= self.settings.contact_tolerance) & self._coupled

    def _scan(
        self,
        pose: np.ndarray,
        origin: np.ndarray,
        col_step: np.ndarray,
        row_step: np.ndarray,
        contact: np.ndarray,
        coupling: np.ndarray,
        speckle_seed: np.uint32,
        frame_key: np.uint32,
        steered: bool = False,
    ) -> TissueSample:
        """One frame's scan lines on the lattice `origin + col * col_step + row * row_step`
        (the beam along `row_step`, `steered` away from the probe's axis or not), through the tissue
        deformed as `last_deformation` says, each line's amplitude scaled by `coupling`
        (`aperture_coupling`), into the grey `_image_lines` and `_label_lines`; returns the
        tissue sampled at the lattice's pixels."""
        probe = self.probe
        grid_points(origin, col_step, row_step, probe.rows, self._points)
        frame = self.last_deformation
        if frame is not None:
            beam = np.ascontiguousarray(pose[:3, 2])
            if steered:  # its columns do not run along the compression: no culling
                reach = np.empty((len(frame.maps), probe.cols, 2))
                reach[..., 0], reach[..., 1] = -np.inf, np.inf
            else:
                reach = column_reach(self._points, probe.rows, probe.pixel_height, beam, frame.maps)
            undeform_points(
                self._points,
                probe.rows,
                probe.pixel_height,
                beam,
                frame.row_shift,
                frame.maps,
                reach,
            )
        sample = self.phantom.sample(
            self._points, out=self._sample, search_radius=self._vessel_search_radius
        )
        if self._clutter_power > 0.0:
            lateral_clutter(
                sample.material,
                self._echogenicity,
                probe.rows,
                self._clutter_power,
                self._aperture_half_cols,
                self.settings.clutter_spread,
                self._clutter_sums,
                self._clutter,
            )
        scan_lines(
            origin,
            col_step,
            row_step,
            frame is not None,
            self._points,
            np.ascontiguousarray(pose[:3, 1]),
            self._elevation_offsets,
            self._elevation_weights,
            sample.material,
            sample.vessel_distance,
            sample.vessel_normal,
            sample.vessel_index,
            self._wall_thickness,
            self._echogenicity,
            self._round_trip_step,
            self._impedance,
            contact,
            self._pulse,
            1.0 / self.settings.scatterer_spacing,
            speckle_seed,
            self.settings.specular_gain,
            self._specular_exponent,
            self.settings.reverberation,
            self._clutter_power > 0.0,
            self._clutter,
            self._has_texture,
            self._texture_inverse_scale,
            self._texture_seed,
            self._texture_variation,
            self._texture_ridges,
            self._echo_real,
            self._echo_imag,
        )
        form_image(
            self._echo_real,
            self._echo_imag,
            self._lateral,
            self._tgc,
            self._noise_amplitude,
            frame_key,
            self._grey_per_log2,
            self._grey_offset,
            self._grey_map,
            sample.material,
            sample.label,
            contact,
            coupling,
            self._image_lines,
            self._label_lines,
        )
        return sample

    def render(
        self, probe_to_phantom: np.ndarray, load: TissueLoad | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """B-mode image and label image, each (rows, cols) uint8, for the probe at
        `probe_to_phantom` (4x4, the TCP pose in the phantom frame, metres), the tissue
        deformed by `load` if the phantom has mechanics."""
        pose = np.asarray(probe_to_phantom, dtype=np.float64)
        if pose.shape != (4, 4) or not is_rigid(pose):
            raise ValueError(
                f"probe_to_phantom must be a rigid 4x4 pose, got shape {pose.shape}"
                + ("" if pose.shape != (4, 4) else " that is not rigid or not finite")
            )
        probe = self.probe
        pixel_to_phantom = pose @ self._image_to_probe
        origin = np.ascontiguousarray(pixel_to_phantom[:3, 3])
        col_step = np.ascontiguousarray(pixel_to_phantom[:3, 0])
        row_step = np.ascontiguousarray(pixel_to_phantom[:3, 1])
        self.last_deformation = None
        if load is not None and self.deformation is not None:
            self.last_deformation = self.deformation.frame(pose, load)
        contact = self.contact(pose, self.last_deformation)
        coupling = aperture_coupling(contact, self._aperture_half_cols)
        frame_key = np.uint32(zlib.crc32(pose.tobytes(), int(self._seed)))
        if len(self._steering) == 1:
            sample = self._scan(
                pose, origin, col_step, row_step, contact, coupling, self._seed, frame_key
            )
        else:
            self._compound_total.fill(0.0)
            self._compound_count.fill(0.0)
            columns_per_row = probe.pixel_height / probe.pixel_width
            for k, angle in enumerate(self._steering):  # the unsteered frame last
                beam_step = row_step + math.tan(angle) * columns_per_row * col_step
                unsteered = k == len(self._steering) - 1
                sample = self._scan(
                    pose,
                    origin,
                    col_step,
                    beam_step,
                    contact,
                    coupling,
                    self._seed if unsteered else mix_seed(int(self._seed), k),
                    frame_key if unsteered else mix_seed(int(frame_key), k),
                    steered=not unsteered,
                )
                accumulate_steered(
                    self._image_lines,
                    sample.material,
                    contact,
                    math.tan(angle) * columns_per_row,
                    self._compound_total,
                    self._compound_count,
                )
            compound_lines(
                self._compound_total,
                self._compound_count,
                sample.material,
                contact,
                self._image_lines,
            )
        image = np.empty((probe.rows, probe.cols), dtype=np.uint8)
        labels = np.empty((probe.rows, probe.cols), dtype=np.uint8)
        lines = self._image_lines
        if self._smoothing is not None:
            smooth_lines(
                lines,
                sample.material,
                contact,
                *self._smoothing,
                self._along,
                self._along_weight,
                self._smoothed_lines,
            )
            lines = self._smoothed_lines
        transpose_pair(lines, self._label_lines, image, labels)
        return image, labels
