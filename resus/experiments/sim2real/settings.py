"""The sim-to-real experiment's settings, and its presets `quick` and `paper`."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from resus.acquisition.patterns import LinearPattern
from resus.errors import ResusError, check_choice, simulator_errors
from resus.execution import Resources, as_json
from resus.segmentation.presets import TrainingPreset, get_preset, pick_preset
from sim.phantom import load_phantom
from sim.ultrasound.scanner import sweep_preset

SIM2REAL_REGIMES = ("us", "aug")
"""Regimes that need nothing but sweeps (no reslices, no ImageNet weights)."""
CURVE_SHAPE_FIELDS = ("label_counts", "splits", "minimum_test_images")
"""`Sim2RealSettings` fields that choose which fine-tunings the curve runs (its k, its splits
and their test sets, which each fine-tuning's key names itself), not what any one computes."""
CURVE_FIELDS = (
    *CURVE_SHAPE_FIELDS, "fine_tune_epochs", "fine_tune_epoch_images", "rehearsal_images"
)  # fmt: skip
"""`Sim2RealSettings` fields that only the few-label curve reads."""


@dataclass(frozen=True)
class Sim2RealSettings:
    """Everything the experiment does besides its real images, seed and device."""

    name: str
    subjects: tuple[int, ...]
    """Simulated subjects of `phantom`, one sweep each."""
    training: str
    """Segmentation training preset (`resus.segmentation.presets`) of every model."""
    phantom: str = "femoral"
    scanner: str = "random"
    """Scanner preset of every sweep: a name, a YAML file (`scanner_preset`), or `random`, one
    drawn per subject."""
    sweep: LinearPattern = field(
        default_factory=lambda: LinearPattern(start=(0.0, -0.04), length=0.06)
    )
    """The nominal sweep; each subject's is moved and tilted (`subject_sweep`)."""
    sweep_offset: float = 0.010
    """Each subject's sweep starts up to this far (m) to either side of the nominal start: a
    sonographer's probe does not centre the vessels in the image."""
    off_vessel_share: float = 0.0
    """Share of the subjects (rounded, drawn from the seed) whose sweep lies off the vessels,
    `off_vessel_offset` to either side of the nominal line: a sonographer's picture does not
    always hold a vessel (10 % of usgra-seg's images hold none), and the muscles and nerve
    beside the vessels are what a model must learn not to call vessel. A vessel that still
    reaches into the picture is labelled as ever."""
    off_vessel_offset: tuple[float, float] = (0.040, 0.050)
    """Range of such a sweep's sideways distance from the nominal line (m): with the 38 mm
    field, its edge 21-31 mm from the vessel pair's midline, past the vein's and the
    artery's far walls, where the bellies beside the pair lie."""
    sweep_tilt_deg: float = 10.0
    """Each subject's probe is tilted by up to this much (degrees) either way along the sweep."""
    contact_forces: tuple[float, float] = (1.5, 3.5)
    """Each subject's sweep holds a contact force drawn in this range (N): sonographers press
    differently, and the deformable phantom's veins go from round to oval. A vascular scan
    presses lightly, to keep the veins open: at 2-9 N (until 2026-12-04) 23 % of the vessel
    cross-sections in seed 0's training frames were over 3 times longer than wide (veins
    pressed to slits), against 3 % in the real images of usgra-seg; at 1.5-3.5 N, 10 %."""
    target_depth_fraction: tuple[float, float] | None = (0.25, 0.65)
    """The sonographer sets each sweep's displayed depth so that the vessels' centres lie at a
    fraction of it drawn in this range (`subject_preset`), within the depths linear presets
    span; None keeps the scanner preset's own depth, blind to the anatomy. In usgra-seg the
    vessels' centres lie at 0.25 / 0.45 / 0.74 of the imaged height (10th / 50th / 90th
    percentile, `resus realism`); 0.35-0.75 (until 2026-12-05) put seed 0's training vessels
    at 0.24 / 0.56 / 0.81, 0.25-0.65 puts them at 0.20 / 0.45 / 0.71, and their areas nearer
    the real ones' too (median 4.3 % of the image, now 3.6 %; real 3.1 %)."""
    ensemble: int = 1
    """Simulation-only models whose mean class probabilities give the simulation-only score:
    member m is the run at seed + m, with simulated subjects of its own, so runs at seeds
    fewer than `ensemble` apart share members. Networks trained apart err apart on real
    images (five 128 px members: 0.348 against 0.284 +- 0.062 alone, README Sim-to-real)."""
    regime: str = "aug"
    """Training regime of the simulation-only model and of every fine-tuning."""
    weight_averaging_epochs: int = 5
    """The simulation-only training runs at the preset's starting rate throughout and its
    model is the mean of the weights after every step of its last this many epochs
    (`TrainingPreset.weight_averaging_epochs`, `resus.segmentation.averaging`): a wider
    minimum of the simulated images' loss, which a shift to real images moves less (128 px,
    seeds 0-3 on usgra-seg: 0.462 -> 0.478 alone, 0.499 -> 0.508 as their ensemble; notebook
    "Weight averaging"). 0: the preset's own schedule and its best epoch. The fine-tunings
    keep the preset's."""
    export_framing_p: float = 0.5
    """Probability that the `aug` regime frames an image like a scanner's export
    (`resus.segmentation.framing`); real exports are not their imaged area."""
    zoom_p: float = 0.5
    """Probability that the `aug` regime zooms into an image (`resus.segmentation.zoom`):
    sonographers enlarge the vessels' part of the image."""
    elastic_p: float = 0.5
    """Probability that the `aug` regime warps an image and its labels elastically
    (`AugmentationConfig.elastic_p`): real veins are seldom ellipses (128 px, five seeds:
    0.319 +- 0.025 against 0.284 +- 0.062 without, README Sim-to-real)."""
    vertical_flip_p: float = 0.5
    """Probability that the `aug` regime turns an image upside down
    (`AugmentationConfig.vertical_flip_p`). No B-mode image is, yet without them the
    simulation-only model scored worse (128 px, five seeds: 0.245 +- 0.092 against 0.296 +-
    0.046, paired p = 0.11; README Sim-to-real)."""
    label_counts: tuple[int, ...] = (0, 5, 10, 25, 50, 100)
    """k: real labelled images a fine-tuning gets."""
    splits: int = 3
    """Random splits of the real images the curve is averaged over."""
    fine_tune_epochs: int = 80
    fine_tune_epoch_images: int = 64
    """Images per fine-tuning epoch: the k images repeated up to this count. Both starts get
    the same budget, long enough for either to converge: at 64 px on split 0 of usgra-seg, 100
    real labels from random weights give vessel IoU 0.000 / 0.002 / 0.302 / 0.402 after 6 /
    20 / 40 / 80 epochs (6 was the default until 2026-12-04: it compared a trained pretrained
    network with an untrained baseline), and from the simulation-only weights 0.352 after 6
    and 0.479 after 80."""
    rehearsal_images: int = 64
    """Simulated frames in every epoch of a fine-tuning from simulation (rehearsal), drawn
    once per fine-tuning (seeded) from the simulation-only model's own training sweeps, in
    the real masks' classes (one vessel class where they do not tell artery from vein); it
    runs fewer epochs so that both starts see the same number of images
    (`fine_tuning_epochs`). From scratch gets none: it is the curve's start without
    simulation. 0: none. Without it five real labels wrecked the start on one split of
    usgra-seg (0.467 -> 0.086; with 64: 0.481; README Sim-to-real)."""
    minimum_test_images: int = 20
    """The least the real set must leave for testing after the largest k."""
    training_cpus: int = 2
    """CPU cores of one training run, and its torch threads (part of what a run's result
    depends on, so the same whichever engine runs it)."""
    training_gpus: float = 0.0
    """GPU share of one training run under Ray (0.25: four runs share a GPU)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "subjects", tuple(int(k) for k in self.subjects))
        object.__setattr__(self, "label_counts", tuple(int(k) for k in self.label_counts))
        where = "Sim2RealSettings"
        if not self.subjects:
            raise ResusError(f"{where}.subjects is empty")
        check_choice(f"{where}.regime", self.regime, SIM2REAL_REGIMES)
        with simulator_errors(f"{where}.phantom"):
            load_phantom(self.phantom)
        with simulator_errors(f"{where}.scanner"):
            sweep_preset(self.scanner, 0, 0)
        counts = self.label_counts
        if not counts or list(counts) != sorted(set(counts)) or counts[0] < 0:
            raise ResusError(
                f"{where}.label_counts must be distinct, increasing and >= 0, got {counts}"
            )
        counted = (
            "ensemble",
            "splits",
            "fine_tune_epochs",
            "fine_tune_epoch_images",
            "minimum_test_images",
            "training_cpus",
        )
        for name in counted:
            if getattr(self, name) < 1:
                raise ResusError(f"{where}.{name} must be at least 1, got {getattr(self, name)}")
        if self.rehearsal_images < 0:
            raise ResusError(f"{where}.rehearsal_images must be >= 0, got {self.rehearsal_images}")
        if not (self.sweep_offset >= 0 and 0 <= self.sweep_tilt_deg < 45):
            raise ResusError(
                f"{where}.sweep_offset must be >= 0 and sweep_tilt_deg in [0, 45), got "
                f"{self.sweep_offset}, {self.sweep_tilt_deg}"
            )
        low, high = self.off_vessel_offset
        if not 0 <= low <= high:
            raise ResusError(
                f"{where}.off_vessel_offset must be (low, high) with 0 <= low <= high (m), "
                f"got {self.off_vessel_offset}"
            )
        low, high = self.contact_forces
        if not 0 < low <= high < 20:
            raise ResusError(
                f"{where}.contact_forces must be (low, high) with 0 < low <= high < 20 N (the "
                f"scanner's force limit), got {self.contact_forces}"
            )
        if self.target_depth_fraction is not None:
            low, high = self.target_depth_fraction
            if not 0 < low <= high < 1:
                raise ResusError(
                    f"{where}.target_depth_fraction must be (low, high) with 0 < low <= high "
                    f"< 1, got {self.target_depth_fraction}"
                )
        shares = ("off_vessel_share", "export_framing_p", "zoom_p", "elastic_p", "vertical_flip_p")
        for name in shares:
            if not 0 <= getattr(self, name) <= 1:
                raise ResusError(f"{where}.{name} must be in [0, 1], got {getattr(self, name)}")
        epochs = get_preset(self.training).max_epochs  # an unknown preset fails here
        if not 0 <= self.weight_averaging_epochs <= epochs:
            raise ResusError(
                f"{where}.weight_averaging_epochs must be in [0, {epochs}] (the max_epochs of "
                f"training preset {self.training!r}), got {self.weight_averaging_epochs}"
            )
        Resources(self.training_cpus, self.training_gpus)  # a bad GPU share fails here too

    def resources(self) -> Resources:
        """What one training run needs of the executor."""
        return Resources(self.training_cpus, self.training_gpus)

    def training_preset(self) -> TrainingPreset:
        """The `training` preset with the experiment's augmentation probabilities."""
        preset = get_preset(self.training)
        augmentation = dataclasses.replace(
            preset.augmentation,
            framing_p=self.export_framing_p,
            zoom_p=self.zoom_p,
            elastic_p=self.elastic_p,
            vertical_flip_p=self.vertical_flip_p,
        )
        return dataclasses.replace(preset, augmentation=augmentation)

    def simulation_training_preset(self) -> TrainingPreset:
        """The simulation-only model's preset: `training_preset`, weight-averaged over the last
        `weight_averaging_epochs` (`TrainingPreset.weight_averaged`)."""
        return self.training_preset().weight_averaged(self.weight_averaging_epochs)

    def fine_tuning_epochs(self, rehearsal: bool) -> int:
        """Epochs of a fine-tuning: `fine_tune_epochs`, or with rehearsal as many as keep its
        images (`fine_tune_epoch_images` real ones and `rehearsal_images` simulated a epoch)
        to the same total, at least one."""
        if not rehearsal or not self.rehearsal_images:
            return self.fine_tune_epochs
        images = self.fine_tune_epochs * self.fine_tune_epoch_images
        return max(1, round(images / (self.fine_tune_epoch_images + self.rehearsal_images)))

    @property
    def pool_size(self) -> int:
        """Real images set aside per split for fine-tuning (the largest k)."""
        return self.label_counts[-1]

    def to_dict(self) -> dict:
        """JSON-able form (tuples become lists)."""
        return as_json(dataclasses.asdict(self))

    def unit_key(self) -> dict:
        """`to_dict` without `ensemble`: what a fine-tuning's result depends on (a member is
        the same run whatever the ensemble's size)."""
        return {name: value for name, value in self.to_dict().items() if name != "ensemble"}

    def simulation_only_key(self) -> dict:
        """`unit_key` without the few-label curve's settings (`CURVE_FIELDS`): what the
        simulation-only training depends on, so that asking for another curve from the same
        simulation reuses its model instead of training it again."""
        return self._unit_key_without(CURVE_FIELDS)

    def fine_tuning_key(self) -> dict:
        """`unit_key` without the curve's shape (`CURVE_SHAPE_FIELDS`): what one fine-tuning
        depends on besides its split, k and start, so that a curve asked for with more k
        reuses the fine-tunings it shares with one run before."""
        return self._unit_key_without(CURVE_SHAPE_FIELDS)

    def _unit_key_without(self, fields: tuple[str, ...]) -> dict:
        """`unit_key` less `fields`."""
        return {name: v for name, v in self.unit_key().items() if name not in fields}


SIM2REAL_PRESETS: dict[str, Sim2RealSettings] = {
    # 36 subjects of 10 mm each, about the frames of six 60 mm sweeps (the training cost),
    # six times the anatomies and scanners: 18 of 20 mm against six of 60 mm, 64 px, 2
    # seeds: 0.237 +- 0.030 against 0.197 +- 0.087; 36 of 10 mm (centred where the 20 mm
    # ones were) against 18 of 20 mm, 128 px, 5 seeds: 0.410 +- 0.023 against 0.389 +- 0.025
    # an ensemble of three: five 128 px members in threes, 0.333 +- 0.021 against
    # 0.284 +- 0.062 for one (README Sim-to-real)
    "quick": Sim2RealSettings(
        name="quick",
        subjects=tuple(range(36)),
        training="cpu128",
        sweep=LinearPattern(start=(0.0, -0.035), length=0.01),
        ensemble=3,
    ),
    "paper": Sim2RealSettings(
        name="paper",
        subjects=tuple(range(24)),
        training="paper",
        ensemble=5,
        weight_averaging_epochs=0,  # not measured at 256 px; the preset's early stopping
        splits=5,
        fine_tune_epochs=40,
        fine_tune_epoch_images=160,
        training_gpus=0.25,
    ),
}
"""`quick`: 36 subjects of 10 mm, the 128 px CPU training preset (a model's training: about
15 minutes on 2 idle cores), weight averaging over its last 5 of 20 epochs; `paper`: 24
subjects at the paper's 256 px ResNet34 U-Net, 5 splits (a GPU), its best epoch (weight
averaging would run all 100 epochs, and was not measured there)."""


def get_sim2real_preset(name: str) -> Sim2RealSettings:
    """The sim-to-real preset called `name`, or a ResusError listing the choices."""
    return pick_preset(SIM2REAL_PRESETS, name)
