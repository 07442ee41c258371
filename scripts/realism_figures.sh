#!/usr/bin/env bash
# The README's Sim-to-real figures: three sweeps of the in-vivo femoral phantom under the
# vascular preset and two random scanner presets, measured beside the real images with
# `resus realism`; the figures land in docs/realism/. Real images: tmkand/usgra-seg (CC BY 4.0).
#
#     bash scripts/realism_figures.sh [REAL_DIR]   # default ../shared/data/real/usgra_seg
set -euo pipefail
real="${1:-../shared/data/real/usgra_seg}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
python -m resus simulate --phantom femoral --scanner vascular --seed 0 --length 0.04 \
    --out "$work/vascular.h5"
python -m resus simulate --phantom femoral --scanner random --seed 1 --length 0.04 \
    --out "$work/random1.h5"
python -m resus simulate --phantom femoral --subject 2 --scanner random --seed 2 --length 0.04 \
    --out "$work/random2.h5"
python -m resus realism --sweep "$work/vascular.h5" --sweep "$work/random1.h5" \
    --sweep "$work/random2.h5" --real "$real" --out docs/realism
