"""Stage 4: U-Net segmentation of femoral artery and vein, and the RESUS training regimes.

Everything here works on plain `LabelledImages` (images, labels, subject) so that frames from
sweeps, reslices from volumes and synthetic test images all go through the same path:
`presets` names every knob, `train` fits one model, `loso` runs the regimes with
leave-one-subject-out evaluation and paired t-tests, `inference` segments new frames.
"""
