"""The paper's experiments in simulation, and the end-to-end demo.

- `data`: simulated scans of phantom subjects, reconstructed and resliced, cached per stage.
- `tables`: the paper's Table I (phantom scans A and B) and Table II (leave-one-subject-out
  over subjects), with their presets and run options.
- `results`: what the experiments return, typed, with results.json's form (`to_dict()`).
- `report`: the experiments' report.md, results.json and figures.
- `demo`: every stage of the pipeline on built-in defaults into one folder; `demo_report`
  renders its report.md from summary.json.
- `realism`: simulated frames measured beside real images (grey levels, contrast, speckle,
  vessels, bright lines), with the table and figures of `resus realism`; a package, one
  module per kind of figure.
- `sim2real`: the sim-to-real experiment, trained on simulation and scored on real images, with
  its few-label curve (a package of its own, imported apart: it needs torch).
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
data: Scan ScanSettings SubjectData prepare_scan prepare_scans prepare_subjects
demo: DemoResult DemoSettings run_demo
demo_report: render_report
realism: ImageSet RealismComparison RealismSettings RealismStats compare measure
realism: read_image_folder read_sweep_set write_realism_report
report: ReportFigures write_phantom_report write_subjects_report
results: GeneralisationCheck IoUSummary PhantomResults RunRecord ScanImages SubjectsResults
tables: EXPERIMENT_PRESETS PAPER_EXPERIMENT QUICK_EXPERIMENT ExperimentPreset RunOptions
tables: generalisation_check get_experiment_preset run_phantom_experiment
tables: run_subjects_experiment
""",
)
