"""The command line: one parser and one code path for

    blender -b -c radiosity_bake IN.blend -o OUT.blend [options]
    python -m radiosity_addon bake IN.blend -o OUT.blend [options]      (with the bpy module)

Exit 0 on success; otherwise a one-line reason on stderr and a non-zero code: 2 bad argument, 3 missing or
unreadable input, 4 nothing to bake or bad scene, 5 unwritable output, 130 interrupted (SIGINT), 143 terminated
(SIGTERM), 1 other. Outputs are all or nothing: OUT.blend, the report and the lightmap files are written under
temporary names, checked, and renamed into place together only when every one of them is whole; on any failure
the earlier files stay as they were. Progress goes to stderr.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import sys
import threading
import time

from .presets import PRESETS, UserSettings

EXIT_BAD_ARGUMENT, EXIT_INPUT, EXIT_SCENE, EXIT_OUTPUT, EXIT_OTHER = 2, 3, 4, 5, 1
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143  # 128 + the signal's number, as shells report them


class CommandError(Exception):
    def __init__(self, code: int, message: str):
        super().__init__(message)
        self.code = code


class _Terminated(BaseException):
    """SIGTERM, raised in the main thread like KeyboardInterrupt is for SIGINT."""


def _number(kind, low: float, high: float):
    """An argparse type: a finite ``kind`` in [low, high]; anything else exits 2 naming the range."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a number, got '{text}'") from None
        if not (math.isfinite(value) and low <= value <= high):
            raise argparse.ArgumentTypeError(f"must be from {low:g} to {high:g}, got {text}")
        return value
    return parse


def build_parser(prog: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=prog, description="Bake diffuse light by radiosity into colour attributes and/or lightmap textures "
        "of a .blend file. Values are irradiance / pi, as Cycles' Diffuse bake with Direct + Indirect and no Color "
        "stores them.")
    parser.add_argument("input", metavar="IN.blend", help="the .blend file to bake")
    parser.add_argument("-o", "--output", metavar="OUT.blend", required=True, help="where to save the baked file")
    parser.add_argument("--overwrite", action="store_true", help="allow OUT.blend to be IN.blend (replaced whole, "
                        "only when the bake succeeds; the old file is kept as OUT.blend1)")
    parser.add_argument("--report", metavar="REPORT.json", help="write a JSON report of outputs and timings")
    parser.add_argument("--target", choices=["vertex_colors", "lightmap", "both"], default="vertex_colors",
                        help="colour attributes, a lightmap texture on a new UV map, or both (default: vertex_colors)")
    parser.add_argument("--quality", choices=[q.lower() for q in PRESETS] + ["custom"], default="medium",
                        help="preset; 'custom' uses the options below (default: medium)")
    parser.add_argument("--element-size", type=_number(float, 1e-3, 1e3), default=0.25,
                        help="element edge length, m (custom)")
    parser.add_argument("--patch-size", type=_number(float, 1e-3, 1e3), default=1.0,
                        help="patch edge length, m (custom)")
    parser.add_argument("--adaptive-passes", type=_number(int, 0, 8), default=1,
                        help="adaptive meshing passes (custom)")
    parser.add_argument("--residual", type=_number(float, 1e-6, 1.0), default=0.01,
                        help="stop at this unshot power share (custom)")
    parser.add_argument("--light-samples", type=_number(int, 1, 64), default=4,
                        help="shadow rays per element: this squared")
    parser.add_argument("--form-factors", choices=["raycast", "hemicube"], default="raycast")
    parser.add_argument("--attribute", default="Radiosity", help="colour attribute name (default: Radiosity)")
    parser.add_argument("--radiosity-mesh", action="store_true", help="also add the element mesh as an object")
    parser.add_argument("--make-local", action="store_true",
                        help="make objects linked from libraries local, with their meshes, so that they hold their "
                             "bake (default: they light the scene but are not baked)")
    density = parser.add_mutually_exclusive_group()
    density.add_argument("--texels-per-meter", type=_number(float, 1e-3, 1e4),
                         help="lightmap density (default: from --quality)")
    density.add_argument("--resolution", type=_number(int, 16, 16384),
                         help="square lightmap size in texels; the density fills it")
    parser.add_argument("--padding", type=_number(int, 1, 64), default=4,
                        help="lightmap texels between charts (default: 4)")
    parser.add_argument("--max-size", type=_number(int, 64, 16384), default=4096,
                        help="texels a side of a lightmap image; more images when the density needs them "
                             "(default: 4096)")
    parser.add_argument("--indirect", choices=["auto", "interpolate", "gather"], default="auto",
                        help="lightmap indirect light: interpolated from the elements, a final gather per texel, or "
                             "auto: the gather where the elements are coarse next to the distances between surfaces "
                             "(custom quality; the presets use auto)")
    parser.add_argument("--gather-samples", type=_number(int, 1, 64), default=8,
                        help="final-gather rays per texel: this squared (custom quality with --indirect gather)")
    parser.add_argument("--uv-map", default="Lightmap", help="name of the lightmap UV map to make")
    parser.add_argument("--existing-uv-map", action="store_true",
                        help="bake onto the UV map --uv-map names, which the objects already have (not changed)")
    parser.add_argument("--lightmap-image", default="Radiosity Lightmap", help="lightmap image and file name")
    parser.add_argument("--lightmap-dir", metavar="DIR",
                        help="folder for the lightmap .exr (default: the folder of OUT.blend)")
    parser.add_argument("--float", action="store_true", help="32-bit float EXR (default: 16-bit half)")
    parser.add_argument("--png-exposure", type=_number(float, -64, 64), metavar="STOPS",
                        help="also write an 8-bit sRGB PNG of the lightmap x 2^STOPS (low dynamic range)")
    parser.add_argument("--seed", type=_number(int, 0, 2 ** 31 - 1), default=0, help="seed of the stratified samples")
    parser.add_argument("--max-memory-gb", type=_number(float, 0, 1 << 20), default=0.0,
                        help="most memory the bake may use, GiB: a larger bake gets coarser elements or is refused "
                             "before the heavy work (default 0: 75%% of this machine's memory)")
    return parser


def run(argv: list[str], prog: str = "radiosity_bake") -> int:
    """Parse, bake, save; returns the exit code (argparse exits with 2 itself on a bad argument)."""
    args = build_parser(prog).parse_args(argv)
    previous = signal.signal(signal.SIGTERM, _terminate) if _main_thread() else None
    try:
        report = _bake(args)
    except CommandError as error:
        print(f"error: {error}", file=sys.stderr)
        return error.code
    except KeyboardInterrupt:
        print("cancelled (interrupted); no file was written", file=sys.stderr)
        return EXIT_INTERRUPTED
    except _Terminated:
        print("cancelled (terminated); no file was written", file=sys.stderr)
        return EXIT_TERMINATED
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    print(f"[radiosity] done: {len(report['objects'])} object(s), {report['elements']} elements, "
          f"residual {report['residual']:.4f}, {report['seconds']:.1f} s", file=sys.stderr)
    return 0


def _terminate(signum, frame):
    raise _Terminated()


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _bake(args) -> dict:
    """The bake behind ``run``: every core error becomes a CommandError with its exit code."""
    from ..core import BakeCancelled, OutputError, SceneError, SettingsError
    try:
        return _checked_bake(args)
    except SettingsError as error:
        raise CommandError(EXIT_BAD_ARGUMENT, str(error)) from None
    except SceneError as error:
        raise CommandError(EXIT_SCENE, str(error)) from None
    except OutputError as error:
        raise CommandError(EXIT_OUTPUT, str(error)) from None
    except BakeCancelled as error:
        raise CommandError(EXIT_OTHER, str(error)) from None
    except MemoryError:
        raise CommandError(EXIT_SCENE, "The bake ran out of memory: set a lower --max-memory-gb so that it adapts, "
                                       "or lower the quality or the lightmap's texel density.") from None


def _checked_bake(args) -> dict:
    import bpy
    from ..core.staged_files import StagedFiles
    from . import job as bake_job
    from .job import Outputs
    from .lightmaps import LightmapOptions
    folder = _check_arguments(args)
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
    outputs = Outputs(args.target.upper(), args.attribute, args.radiosity_mesh, lightmap, folder, args.make_local)
    started = time.perf_counter()
    job = bake_job.prepare(bpy.context, user, outputs)
    bake_job.solve(job, _progress_to_stderr(), lambda: False)
    with StagedFiles() as staged:
        report = bake_job.apply(job, staged)
        report["seconds"] = time.perf_counter() - started
        report["input"], report["output"] = os.path.abspath(args.input), os.path.abspath(args.output)
        if os.path.isfile(args.output) and bpy.context.preferences.filepaths.save_version > 0:
            # Blender's own backup of the file a save replaces (Save Versions), made in the same commit.
            staged.stage(args.output + "1", lambda path: shutil.copy2(args.output, path))
        staged.stage(args.output, _save_blend, _check_blend)
        if args.report:
            staged.stage(args.report, lambda path: _write_json(path, report), _check_json)
        staged.commit()
    return report


def _check_arguments(args) -> str:
    """What argparse cannot check alone: the input file, the output against the input, the resolution against
    the maximum size, and that every output folder is writable; returns the lightmaps' folder."""
    if os.path.isdir(args.input):
        raise CommandError(EXIT_INPUT, f"the input is a folder, not a .blend file: {args.input}")
    if not os.path.isfile(args.input):
        raise CommandError(EXIT_INPUT, f"input file not found: {args.input}")
    if os.path.exists(args.output) and os.path.samefile(args.input, args.output) and not args.overwrite:
        raise CommandError(EXIT_BAD_ARGUMENT, f"the output is the input file {args.input}: pass --overwrite to "
                                              "replace it, or give another -o")
    if args.resolution is not None and args.resolution > args.max_size:
        raise CommandError(EXIT_BAD_ARGUMENT, f"--resolution {args.resolution} is above --max-size "
                                              f"{args.max_size}: raise --max-size or lower the resolution")
    folder = os.path.abspath(args.lightmap_dir or os.path.dirname(os.path.abspath(args.output)))
    for path, what in ((args.output, "output"), (args.report, "report")):
        if path and not _writable(path):
            raise CommandError(EXIT_OUTPUT, f"cannot write the {what} file: {path} (missing or read-only folder, "
                                            "or not a regular file)")
    if args.target != "vertex_colors" and not _writable(os.path.join(folder, "lightmap.exr")):
        raise CommandError(EXIT_OUTPUT, f"cannot write lightmaps into {folder} (missing or read-only folder)")
    return folder


def _save_blend(path: str) -> None:
    """Save the baked file as a copy at ``path`` (the session keeps its own file name; relative paths are
    remapped for ``path``'s folder, which is the target's)."""
    import bpy
    try:
        bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    except RuntimeError as error:
        raise OSError(str(error).strip().splitlines()[-1]) from None


def _check_blend(path: str) -> None:
    """Blender reads the saved file's list of objects back (a truncated file fails: 'Missing DNA block')."""
    import bpy
    try:
        with bpy.data.libraries.load(path) as (source, _):
            names = list(source.objects)
    except (OSError, RuntimeError) as error:
        raise OSError(f"the saved file does not read back ({str(error).strip().splitlines()[-1]})") from None
    missing = {obj.name for obj in bpy.data.objects if obj.library is None and obj.users} - set(names)
    if missing:
        raise OSError(f"the saved file reads back without {len(missing)} of its objects")


def _write_json(path: str, report: dict) -> None:
    with open(path, "w", encoding="utf-8") as handle:
        json.dump(report, handle, indent=2)


def _check_json(path: str) -> None:
    try:
        with open(path, encoding="utf-8") as handle:
            json.load(handle)
    except ValueError as error:
        raise OSError(f"the report does not read back ({error})") from None


def _writable(path: str) -> bool:
    """A regular file (or none yet) in a folder we may write to: outputs are renamed into place there."""
    folder = os.path.dirname(os.path.abspath(path))
    return os.path.isdir(folder) and os.access(folder, os.W_OK) and (not os.path.exists(path) or
                                                                      os.path.isfile(path))


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
