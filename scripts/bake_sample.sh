#!/usr/bin/env bash
# Bake the bundled Cornell box end to end on a fresh machine: set up .venv, make the sample scene if needed,
# bake it with the command line into colour attributes and a lightmap, and render a preview picture of the light.
# Leaves out/cornell_box_baked.blend, out/Radiosity_Lightmap.exr, out/cornell_box_report.json and
# out/cornell_box_preview.png. Extra arguments go to the bake command (e.g. --quality high, --target vertex_colors).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup_venv.sh
[ -f sample_blends/cornell_box.blend ] || .venv/bin/python sample_blends/make_samples.py
mkdir -p out
.venv/bin/python -m radiosity_addon bake sample_blends/cornell_box.blend -o out/cornell_box_baked.blend \
  --report out/cornell_box_report.json --target both "$@"
.venv/bin/python scripts/render_preview.py out/cornell_box_baked.blend out/cornell_box_preview.png
echo "Baked: out/cornell_box_baked.blend  report: out/cornell_box_report.json  preview: out/cornell_box_preview.png"
