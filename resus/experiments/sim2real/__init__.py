"""The sim-to-real experiment: a U-Net trained on simulation only, scored on real images, and
what simulation pretraining is worth once a few real labels exist.

1. Simulation only. One sweep per subject of the in-vivo phantom, each imaged by its own
   randomised scanner preset (`sim.ultrasound.scanner.sweep_preset`), trains one U-Net; no
   real image enters that training. The model (`sim_only/checkpoint.pt`) is scored on every
   real image (`sim_only/evaluation/`: metrics.json and overlays, as `resus evaluate` writes).
   With `ensemble` > 1, members 1, 2, ... are the same run at the next seeds (subjects,
   scanners and training of their own, in `sim_only/member_M/` and `data/member_M/`), and
   the figure is their ensemble's (`resus.segmentation.load_ensemble`); each member is
   scored alone too.
2. The few-label curve (`few_label`): real labels fine-tune a U-Net from the simulation-only
   weights and from random ones, on seeded splits of the real images, each k scored on its
   split's test set.

The sweeps, the simulation-only training and every fine-tuning are units on an executor
(`resus.execution`: local worker processes or a Ray cluster; `units`), each recorded when it
finishes, so a rerun resumes and the figures do not depend on the engine.

- `settings`: `Sim2RealSettings` and the presets `quick` and `paper`.
- `subjects`: the simulated side, one sweep per subject, each scanned and imaged its own way.
- `few_label`: the real images' splits, the fine-tunings (with rehearsal) and the curve.
- `units`: the training runs as resumable units.
- `experiment`: `run_sim2real`, all of it into one folder; `Sim2RealResult`, results.json.
- `report`: report.md, the curve's and the examples' figures.
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
experiment: Sim2RealResult run_sim2real
few_label: FROM_SCRATCH FROM_SIMULATION INITIALISATIONS CurvePoint RealSplit Spread
few_label: curve_summary fine_tune real_splits rehearsal_frames repeated_to
report: pretraining_verdict write_sim2real_report
settings: SIM2REAL_PRESETS Sim2RealSettings get_sim2real_preset
subjects: off_vessel_subjects simulate_subjects subject_job subject_preset subject_sweep
subjects: sweep_provenance
""",
)
