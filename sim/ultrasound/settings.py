"""Every knob of the synthetic B-mode simulator, each with a documented default."""

from __future__ import annotations

from dataclasses import dataclass

MAX_STEERING = 0.35
"""The largest steering angle (rad, 20 degrees) a compounded frame may use: beyond it a linear
array's grating lobes and the elements' directivity make steered frames unusable."""


@dataclass(frozen=True)
class UltrasoundSettings:
    """Acoustic, beam and display parameters of the B-mode simulator (SI units, dB where named).

    The defaults describe a 7.5 MHz vascular linear probe on a clinical scanner: about 0.5 mm
    lateral resolution at a 25 mm focus, a 1 mm elevational slice (from `LinearProbe`), time-gain
    compensation for 0.5 dB/cm/MHz and a 50 dB display dynamic range.
    """

    speed_of_sound: float = 1540.0
    """Speed of sound used for the wavelength and the pulse length (m/s)."""
    fractional_bandwidth: float = 0.6
    """Pulse bandwidth (full width at half maximum) as a fraction of the centre frequency;
    sets the length of the axial Gabor pulse."""
    lateral_resolution: float = 0.5e-3
    """Lateral beam width (full width at half maximum) at the focal depth (m)."""
    focal_depth: float = 0.025
    """Depth of the transmit/receive focus below the transducer face (m)."""
    depth_of_field: float = 0.015
    """Distance from the focus at which the lateral beam has widened by a factor sqrt(2) (m)."""
    scatterer_spacing: float = 0.2e-3
    """Spacing of the phantom-fixed scatterer lattice (m). The field is interpolated between
    nodes, so this is also the smallest speckle grain; keep it near the pixel size."""
    elevation_samples: int = 4
    """Planes summed across the elevational slice (weighted by its Gaussian beam profile)."""
    tgc_attenuation: float | None = None
    """Attenuation that time-gain compensation undoes (dB/cm/MHz), the same at every depth:
    tissue that attenuates exactly this much looks uniformly bright with depth; less
    attenuating media (blood) brighten what lies below them (posterior enhancement). None:
    the phantom's layers (`PhantomSpec.attenuation_below_skin`), each undone over its own
    depths, as a sonographer sets the sliders for evenly bright tissue."""
    specular_gain: float = 120.0
    """Echo amplitude of a flat interface with reflection coefficient 1 at normal incidence,
    relative to the root-mean-square speckle amplitude of echogenicity-1 tissue."""
    specular_angle: float = 0.25
    """Incidence angle (rad) between beam and interface normal at which a specular vessel-wall
    echo has fallen to half its normal-incidence amplitude."""
    persistence: float = 0.0
    """Frame averaging of the live stream (`sim.ultrasound.persistence`): the weight of the
    previous displayed image in the next, 0 to below 1. It acts on a stream of frames (the
    simulated probe's), never on one rendered pose. 0: none."""
    reverberation: float = 0.0
    """Reflection coefficient of the transducer face for returning echoes: every specular echo
    from depth d comes back once more as if from 2d, weaker by this times the interface's own
    reflection and attenuation (the ghost copies of a bright fascia or wall deeper in the
    image). 0: none."""
    electronic_noise_db: float = -15.0
    """Receiver noise (RMS amplitude, dB relative to echogenicity-1 speckle) as it shows at the
    deepest row after time-gain compensation, for a phantom whose `noise_level` is 1; it scales
    linearly with the level. Being added before the TGC, it fades towards the face, so it
    shows as snow in deep lumens and shadows."""
    gain_db: float = 32.0
    """Display gain (dB): speckle of unit root-mean-square amplitude shows at grey
    `255 * gain_db / dynamic_range_db`."""
    dynamic_range_db: float = 50.0
    """Range of echo levels (dB) mapped onto grey levels 0..255 by the log compression."""
    tgc_sliders_db: tuple[float, ...] = ()
    """Offsets (dB) of the console's TGC sliders, evenly spaced from the face to the deepest
    row and interpolated linearly between them (a real console has six to eight), on top of
    the compensation `tgc_attenuation` implies. Empty: no offsets."""
    clutter_db: float | None = None
    """Side-lobe clutter: scatter power (dB) relative to the mean scatter power of the tissue
    within `active_aperture` at the same depth, added with the tissue's own speckle grain (it is
    that tissue seen through the side lobes). It fills lumens with faint echoes and barely
    changes tissue; None: no clutter."""
    clutter_spread: float = 0.0
    """Share of the clutter power (`clutter_db`) taken from the whole image row rather than
    from within `active_aperture`: the far side lobes, grating lobes and reverberation of the
    body wall see tissue well beyond one aperture, so a lumen wider than the aperture does not
    darken towards its middle. 0 to 1; 0: the aperture's tissue only."""
    active_aperture: float = 10.0e-3
    """Width (m) of the elements that form one scan line: the tissue its side lobes see
    (`clutter_db`), and how far an element without coupling dims its neighbours' lines
    (`lost_coupling`)."""
    speckle_smoothing: float = 0.0
    """Speckle reduction: Gaussian standard deviation (m) of the scanner's smoothing of the
    log-compressed image across the beam, as its speckle-reduction filter and the
    interpolation between scan lines do (real exports show grains several pixels wide). 0:
    none."""
    speckle_smoothing_axial: float | None = None
    """The same along the beam (m); None: as across it. Less than across it for a scanner
    whose filter spares the fine axial grain its pulse resolves (what that did to simulated
    training images: `sim.ultrasound.scanner.RANDOM_RANGES`)."""
    grey_gamma: float = 1.0
    """Grey map: a log-compressed level g shows as `255 * (g / 255) ** grey_gamma`; above 1
    darkens the mid-greys, as vascular presets do, and keeps black and white."""
    compound_frames: int = 1
    """Spatial compounding (`sim.ultrasound.compounding`): frames steered at evenly spread
    angles averaged into each displayed frame, odd (the unsteered one among them), 1-9.
    1: none. Each frame costs about as much as an uncompounded one."""
    compound_angle: float = 0.0
    """The largest steering angle (rad) of a compounded frame, 0 to 0.35 (20 degrees)."""
    contact_tolerance: float = 0.5e-3
    """Largest gap (m) between a transducer element and the skin that gel still couples;
    columns whose element is further above the skin stay black. A line whose element is
    coupled but part of its active aperture is not is dimmed by the coupled share squared
    (transmit and receive each scale with it, to first order): images fade into their black
    margins over half an aperture, as real ones do."""
    lost_coupling: tuple[float, float] = (0.0, 0.0)
    """Shares of the array's width, at its first and at its last column, whose elements have
    lost coupling wherever the probe is (rocked onto one edge, the gel run dry under it): they
    image nothing, like elements above the skin. Each 0 to 0.5."""

    def __post_init__(self) -> None:
        positive = (
            "speed_of_sound",
            "fractional_bandwidth",
            "lateral_resolution",
            "focal_depth",
            "depth_of_field",
            "scatterer_spacing",
            "specular_angle",
            "dynamic_range_db",
            "active_aperture",
            "grey_gamma",
        )
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(
                    f"ultrasound setting {name} must be positive, got {getattr(self, name)}"
                )
        tgc = self.tgc_attenuation
        if tgc is not None and not tgc >= 0:
            raise ValueError(f"ultrasound setting tgc_attenuation must be non-negative, got {tgc}")
        axial = self.speckle_smoothing_axial
        if axial is not None and not axial >= 0:
            raise ValueError(
                f"ultrasound setting speckle_smoothing_axial must be non-negative, got {axial}"
            )
        for name in ("specular_gain", "contact_tolerance", "speckle_smoothing"):
            if not getattr(self, name) >= 0:
                raise ValueError(
                    f"ultrasound setting {name} must be non-negative, got {getattr(self, name)}"
                )
        if not 1 <= self.elevation_samples <= 16:
            raise ValueError(
                f"ultrasound setting elevation_samples must be 1..16, got {self.elevation_samples}"
            )
        if not self.specular_angle < 1.5:
            raise ValueError(
                f"ultrasound setting specular_angle must be below pi/2, got {self.specular_angle}"
            )
        if not 0 <= self.clutter_spread <= 1:
            raise ValueError(
                f"ultrasound setting clutter_spread must be in [0, 1], got {self.clutter_spread}"
            )
        for name in ("reverberation", "persistence"):
            if not 0 <= getattr(self, name) < 1:
                raise ValueError(
                    f"ultrasound setting {name} must be in [0, 1), got {getattr(self, name)}"
                )
        if not (1 <= self.compound_frames <= 9 and self.compound_frames % 2 == 1):
            raise ValueError(
                "ultrasound setting compound_frames must be odd and 1..9, "
                f"got {self.compound_frames}"
            )
        if not 0 <= self.compound_angle <= MAX_STEERING:
            raise ValueError(
                f"ultrasound setting compound_angle must be in [0, {MAX_STEERING}] rad, "
                f"got {self.compound_angle}"
            )
        if self.compound_frames > 1 and self.compound_angle == 0:
            raise ValueError(
                f"ultrasound setting compound_angle must be > 0 to compound "
                f"{self.compound_frames} frames, got 0"
            )
        if len(self.lost_coupling) != 2 or not all(0 <= s <= 0.5 for s in self.lost_coupling):
            raise ValueError(
                "ultrasound setting lost_coupling must be two shares of the array's width, "
                f"each 0 to 0.5, got {self.lost_coupling}"
            )
        if len(self.tgc_sliders_db) == 1:
            raise ValueError("ultrasound setting tgc_sliders_db needs at least two sliders, got 1")
