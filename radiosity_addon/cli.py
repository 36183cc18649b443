"""The command line: one parser and one code path for

    blender -b -c radiosity_bake IN.blend -o OUT.blend [options]
    python -m radiosity_addon bake IN.blend -o OUT.blend [options]      (with the bpy module)

Exit 0 on success; otherwise a one-line reason on stderr and a non-zero code:
2 bad argument, 3 missing or unreadable input, 4 nothing to bake or bad scene, 5 unwritable output, 1 other.
Progress goes to stderr.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

from .presets import PRESETS, UserSettings

EXIT_BAD_ARGUMENT, EXIT_INPUT, EXIT_SCENE, EXIT_OUTPUT, EXIT_OTHER = 2, 3, 4, 5, 1


class CommandError(Exception):
    def __init__(self, code: int, message: str):
        super().__init__(message)
        self.code = code


def build_parser(prog: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=prog, description="Bake diffuse light by radiosity into colour attributes and/or lightmap textures "
        "of a .blend file. Values are irradiance / pi, as Cycles' Diffuse bake with Direct + Indirect and no Color "
        "stores them.")
    parser.add_argument("input", metavar="IN.blend", help="the .blend file to bake")
    parser.add_argument("-o", "--output", metavar="OUT.blend", required=True, help="where to save the baked file")
    parser.add_argument("--report", metavar="REPORT.json", help="write a JSON report of outputs and timings")
    parser.add_argument("--target", choices=["vertex_colors", "lightmap", "both"], default="vertex_colors",
                        help="colour attributes, a lightmap texture on a new UV map, or both (default: vertex_colors)")
    parser.add_argument("--quality", choices=[q.lower() for q in PRESETS] + ["custom"], default="medium",
                        help="preset; 'custom' uses the options below (default: medium)")
    parser.add_argument("--element-size", type=float, default=0.25, help="element edge length, m (custom)")
    parser.add_argument("--patch-size", type=float, default=1.0, help="patch edge length, m (custom)")
    parser.add_argument("--adaptive-passes", type=int, default=1, help="adaptive meshing passes (custom)")
    parser.add_argument("--residual", type=float, default=0.01, help="stop at this unshot power share (custom)")
    parser.add_argument("--light-samples", type=int, default=4, help="shadow rays per element: this squared")
    parser.add_argument("--form-factors", choices=["raycast", "hemicube"], default="raycast")
    parser.add_argument("--attribute", default="Radiosity", help="colour attribute name (default: Radiosity)")
    parser.add_argument("--radiosity-mesh", action="store_true", help="also add the element mesh as an object")
    density = parser.add_mutually_exclusive_group()
    density.add_argument("--texels-per-meter", type=float, help="lightmap density (default: from --quality)")
    density.add_argument("--resolution", type=int, help="square lightmap size in texels; the density fills it")
    parser.add_argument("--padding", type=int, default=4, help="lightmap texels between charts (default: 4)")
    parser.add_argument("--max-size", type=int, default=4096,
                        help="texels a side of a lightmap image; more images when the density needs them "
                             "(default: 4096)")
    parser.add_argument("--indirect", choices=["auto", "interpolate", "gather"], default="auto",
                        help="lightmap indirect light: interpolated from the elements, a final gather per texel, or "
                             "auto: the gather where the elements are coarse next to the distances between surfaces "
                             "(custom quality; the presets use auto)")
    parser.add_argument("--gather-samples", type=int, default=8,
                        help="final-gather rays per texel: this squared (custom quality with --indirect gather)")
    parser.add_argument("--uv-map", default="Lightmap", help="name of the lightmap UV map to make")
    parser.add_argument("--existing-uv-map", action="store_true",
                        help="bake onto the UV map --uv-map names, which the objects already have (not changed)")
    parser.add_argument("--lightmap-image", default="Radiosity Lightmap", help="lightmap image and file name")
    parser.add_argument("--lightmap-dir", metavar="DIR",
                        help="folder for the lightmap .exr (default: the folder of OUT.blend)")
    parser.add_argument("--float", action="store_true", help="32-bit float EXR (default: 16-bit half)")
    parser.add_argument("--png-exposure", type=float, metavar="STOPS",
                        help="also write an 8-bit sRGB PNG of the lightmap x 2^STOPS (low dynamic range)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the stratified samples")
    parser.add_argument("--max-memory-gb", type=float, default=0.0,
                        help="most memory the bake may use, GiB: a larger bake gets coarser elements or is refused "
                             "before the heavy work (default 0: 75%% of this machine's memory)")
    return parser


def run(argv: list[str], prog: str = "radiosity_bake") -> int:
    """Parse, bake, save; returns the exit code (argparse exits with 2 itself on a bad argument)."""
    args = build_parser(prog).parse_args(argv)
    try:
        report = _bake(args)
    except CommandError as error:
        print(f"error: {error}", file=sys.stderr)
        return error.code
    print(f"[radiosity] done: {len(report['objects'])} object(s), {report['elements']} elements, "
          f"residual {report['residual']:.4f}, {report['seconds']:.1f} s", file=sys.stderr)
    return 0


def _bake(args) -> dict:
    import bpy
    from ..core import BakeCancelled, SceneError
    from . import job as bake_job
    from .job import Outputs
    from .lightmaps import LightmapOptions
    for name in ("texels_per_meter", "resolution", "padding", "max_size", "gather_samples"):
        value = getattr(args, name)
        if value is not None and value <= 0:
            raise CommandError(EXIT_BAD_ARGUMENT, f"--{name.replace('_', '-')} must be positive, got {value}")
    if not (math.isfinite(args.max_memory_gb) and args.max_memory_gb >= 0):
        raise CommandError(EXIT_BAD_ARGUMENT, f"--max-memory-gb must be a positive number (0: the default), "
                                              f"got {args.max_memory_gb}")
    if not os.path.isfile(args.input):
        raise CommandError(EXIT_INPUT, f"input file not found: {args.input}")
    folder = os.path.abspath(args.lightmap_dir or os.path.dirname(os.path.abspath(args.output)))
    for path, what in ((args.output, "output"), (args.report, "report")):
        if path and not _writable(path):
            raise CommandError(EXIT_OUTPUT, f"cannot write the {what} file: {path} (missing or read-only folder)")
    if args.target != "vertex_colors" and not _writable(os.path.join(folder, "lightmap.exr")):
        raise CommandError(EXIT_OUTPUT, f"cannot write lightmaps into {folder} (missing or read-only folder)")
    try:
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(args.input), load_ui=False)
    except RuntimeError as error:
        raise CommandError(EXIT_INPUT, f"cannot read {args.input}: {str(error).strip().splitlines()[-1]}")
    user = UserSettings(args.quality.upper(), args.element_size, args.patch_size, args.adaptive_passes,
                        args.residual, args.light_samples, args.form_factors, args.seed, args.gather_samples,
                        args.texels_per_meter or 0.0, args.indirect, args.max_memory_gb)
    lightmap = LightmapOptions(args.uv_map, args.lightmap_image, args.texels_per_meter, args.resolution,
                               args.padding, args.max_size, half=not args.float, png_exposure=args.png_exposure,
                               existing_uv_map=args.existing_uv_map)
    outputs = Outputs(args.target.upper(), args.attribute, args.radiosity_mesh, lightmap, folder)
    started = time.perf_counter()
    try:
        job = bake_job.prepare(bpy.context, user, outputs)
        bake_job.solve(job, _progress_to_stderr(), lambda: False)
    except SceneError as error:
        raise CommandError(EXIT_SCENE, str(error))
    except BakeCancelled as error:
        raise CommandError(EXIT_OTHER, str(error))
    try:
        report = bake_job.apply(job)
    except SceneError as error:  # a lightmap file that cannot be written
        raise CommandError(EXIT_OUTPUT, str(error))
    report["seconds"] = time.perf_counter() - started
    report["input"], report["output"] = os.path.abspath(args.input), os.path.abspath(args.output)
    try:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.output))
    except RuntimeError as error:
        raise CommandError(EXIT_OUTPUT, f"cannot save {args.output}: {str(error).strip().splitlines()[-1]}")
    if args.report:
        with open(args.report, "w", encoding="utf-8") as handle:
            json.dump(report, handle, indent=2)
    return report


def _writable(path: str) -> bool:
    folder = os.path.dirname(os.path.abspath(path))
    return os.path.isdir(folder) and os.access(folder, os.W_OK) and (not os.path.exists(path) or
                                                                      os.access(path, os.W_OK))


def _progress_to_stderr():
    last = {"message": None, "time": 0.0}

    def progress(fraction, message):
        now = time.perf_counter()
        if message != last["message"] and now - last["time"] > 0.5:
            print(f"[radiosity] {message}", file=sys.stderr, flush=True)
            last.update(message=message, time=now)
    return progress


def blender_command(argv: list[str]) -> int:
    """Entry point registered with bpy.utils.register_cli_command('radiosity_bake', ...)."""
    try:
        return run(list(argv), prog="blender -b -c radiosity_bake")
    except SystemExit as exit_:  # argparse: --help (0) or a bad argument (2)
        return int(exit_.code or 0)
