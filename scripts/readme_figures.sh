#!/usr/bin/env bash
# The README's figures of `resus demo` and `resus experiment phantom|subjects`, regenerated
# into docs/ exactly as the README quotes them, so that they never drift from the code:
#
#     bash scripts/readme_figures.sh [demo] [phantom] [subjects] [femoral]   # default: all four
#
#   demo      a fresh `resus demo` at its defaults; its report, summary.json and pictures
#             go to docs/demo/ (about 8 minutes on an idle 2-core CPU)
#   phantom   `resus experiment phantom --preset quick` into docs/experiment_phantom_quick/
#   subjects  `resus experiment subjects --preset quick` into docs/experiment_subjects_quick/
#             (4 subjects x 3 regimes x 3 seeds: about an hour on 2 cores)
#   femoral   both tables on the femoral phantom through the vascular preset, into
#             docs/experiment_{phantom,subjects}_femoral_quick/ (regimes us, aug, resus at
#             2 seeds: about 20 minutes on 2 cores)
#
# Scans and finished training runs are cached in $RESUS_FIGURES_CACHE (default
# /tmp/resus_readme_figures): a rerun after a crash trains only what had not finished. The
# demo always starts from an empty folder, so its wall times are a first run's. Run it with
# the project's venv active (or PYTHON=.venv/bin/python). The Sim-to-real figures come from
# scripts/realism_figures.py and `resus experiment sim2real` (see the README).
set -euo pipefail
cd "$(dirname "$0")/.."
python="${PYTHON:-python}"
cache="${RESUS_FIGURES_CACHE:-/tmp/resus_readme_figures}"
parts=("$@")
[ ${#parts[@]} -gt 0 ] || parts=(demo phantom subjects femoral)
for part in "${parts[@]}"; do
    case "$part" in
        demo | phantom | subjects | femoral) ;;
        *) echo "error: unknown part '$part'; choose demo, phantom, subjects or femoral" >&2; exit 2 ;;
    esac
done
mkdir -p "$cache"

demo() {
    rm -rf "$cache/demo"
    "$python" -m resus demo --out "$cache/demo"
    rm -rf docs/demo
    mkdir -p docs/demo
    # the report and what it shows inline; meshes, volumes, sweeps and checkpoints stay out
    (cd "$cache/demo" && cp --parents report.md summary.json timings.json ./*.png models/*/*/curves.png \
        vessels/resus/vessel_map.png vessels/resus/needle.png "$OLDPWD/docs/demo/")
}

experiment() {
    "$python" -m resus experiment "$1" --preset quick --out "docs/experiment_$1_quick" \
        --data "$cache/quick_data"
}

femoral() {
    local femoral=(--preset quick --phantom femoral --scanner vascular --data "$cache/femoral_data")
    "$python" -m resus experiment phantom "${femoral[@]}" --out docs/experiment_phantom_femoral_quick
    "$python" -m resus experiment subjects "${femoral[@]}" --regimes us,aug,resus --seeds 2 \
        --out docs/experiment_subjects_femoral_quick
}

for part in "${parts[@]}"; do
    case "$part" in
        demo) demo ;;
        femoral) femoral ;;
        *) experiment "$part" ;;
    esac
done
