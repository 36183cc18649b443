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
from dataclasses import replace

import bpy

from ..core import BakeCancelled, OutputError, SceneError, SettingsError
from ..core.atlas import atlas_size
from ..core.staged_files import StagedFiles, claimed
from . import job as bake_job
from .settings import BY_NAME, SETTINGS, Setting, UserSettings

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
    """The command line: IN.blend, -o, --overwrite and --report, then one option per setting of the table
    (settings.SETTINGS), with its bounds as a range."""
    parser = argparse.ArgumentParser(
        prog=prog, description="Bake diffuse light by radiosity into colour attributes and/or lightmap textures "
        "of a .blend file. Values are irradiance / pi, as Cycles' Diffuse bake with Direct + Indirect and no Color "
        "stores them.")
    parser.add_argument("input", metavar="IN.blend", help="the .blend file to bake")
    parser.add_argument("-o", "--output", metavar="OUT.blend", required=True, help="where to save the baked file")
    parser.add_argument("--overwrite", action="store_true", help="allow OUT.blend to be IN.blend (replaced whole, "
                        "only when the bake succeeds; the old file is kept as OUT.blend1)")
    parser.add_argument("--report", metavar="REPORT.json", help="write a JSON report of outputs and timings")
    parser.add_argument("--relight", metavar="CACHE", help="write the outputs from the relighting cache a bake with "
                        "--cache wrote, for the lamps' strengths and colours, emission strengths, world strength "
                        "and light groups of IN.blend now, without baking (refused, naming it, if anything else "
                        "changed)")
    for setting in SETTINGS:
        if setting.flag:
            parser.add_argument(setting.flag, dest=setting.name, default=argparse.SUPPRESS, **_option(setting))
        if setting.flag and setting.kind is bool:  # the file's setting may be on: a switch back
            parser.add_argument(f"--no-{setting.flag[2:]}", dest=setting.name, default=argparse.SUPPRESS,
                                action="store_const", const=setting.negate, help=f"undoes {setting.flag}")
    return parser


def _option(setting: Setting) -> dict:
    """argparse keywords for one setting: a switch, a choice (enum identifiers in lower case) or a number in its
    bounds; help gives the default (the bpy property's)."""
    text = setting.help.replace("%", "%%")
    if setting.kind is bool:
        return {"action": "store_const", "const": not setting.negate,
                "help": f"sets {setting.label} off: {text}" if setting.negate else text}
    if setting.items:
        return {"choices": [item[0].lower() for item in setting.items], "type": str.lower,
                "help": f"{text} (default: the input's; {str(setting.default).lower()} in a new file)"}
    metavar = setting.flag.lstrip("-").upper().replace("-", "_")
    if setting.kind is str:
        return {"metavar": metavar, "help": f"{text} (default: the input's; '{setting.default}' in a new file)"}
    return {"type": _number(setting.kind, setting.low, setting.high), "metavar": metavar,
            "help": f"{text} (default: the input's; {setting.default:g} in a new file; from {setting.low:g} to "
                    f"{setting.high:g})"}


def user_settings(args: argparse.Namespace, saved: UserSettings = UserSettings()) -> UserSettings:
    """UserSettings from parsed arguments: the options given, and for the rest the ``saved`` ones (the input
    file's Radiosity panel, as Blender renders a file with its own render settings; the table's defaults for a
    file saved without the add-on). An enum's choice is matched to its identifier; --png-exposure also asks for
    the PNG."""
    given = {name: value for name, value in vars(args).items() if name in BY_NAME}
    for name, value in given.items():
        items = {item[0].lower(): item[0] for item in BY_NAME[name].items}
        given[name] = items.get(value, value)
    if "lightmap_png_exposure" in given:
        given["lightmap_png"] = True
    return replace(saved, **given)


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
    _check_input(args)
    try:
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(args.input), load_ui=False)
    except RuntimeError as error:
        raise CommandError(EXIT_INPUT, f"cannot read {args.input}: {str(error).strip().splitlines()[-1]}")
    saved = getattr(bpy.context.scene, "radiosity", None)
    user = user_settings(args, saved.user_settings() if saved is not None else UserSettings())
    folder = _check_outputs(args, user)
    with claimed(args.output):
        return _claimed_bake(args, user, folder)


def _claimed_bake(args, user: UserSettings, folder: str) -> dict:
    """Bake the open file and write every output, with the output file claimed (core.staged_files.claimed)."""
    started = time.perf_counter()
    if args.relight:
        job = bake_job.relight_job(bpy.context, user, folder, os.path.abspath(args.relight))
    else:
        job = bake_job.prepare(bpy.context, user, folder)
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


def _check_input(args) -> None:
    """What argparse cannot check alone about the files read, before the input is opened: the input and the
    relighting cache exist, and the output is not the input unless --overwrite is given."""
    if os.path.isdir(args.input):
        raise CommandError(EXIT_INPUT, f"the input is a folder, not a .blend file: {args.input}")
    if not os.path.isfile(args.input):
        raise CommandError(EXIT_INPUT, f"input file not found: {args.input}")
    if args.relight and not os.path.isfile(args.relight):
        raise CommandError(EXIT_INPUT, f"relighting cache not found: {args.relight}")
    if os.path.exists(args.output) and os.path.samefile(args.input, args.output) and not args.overwrite:
        raise CommandError(EXIT_BAD_ARGUMENT, f"the output is the input file {args.input}: pass --overwrite to "
                                              "replace it, or give another -o")


def _check_outputs(args, user: UserSettings) -> str:
    """What argparse cannot check alone about the settings and outputs, before any work: --relight against a
    cache to write, the lightmap's size settings, and that every output folder is writable; returns the
    lightmaps' absolute folder (a leading // is the folder of OUT.blend)."""
    if args.relight and "relight_cache" in vars(args):  # given: a cache path saved in the file is not used
        raise CommandError(EXIT_BAD_ARGUMENT, "--relight writes from a cache and bakes nothing, so it cannot write "
                                              "a new one with --cache")
    if user.lightmaps:
        atlas_size(user.texels_per_metre, user.lightmap_resolution, 1.0, user.lightmap_padding,
                   user.lightmap_max_size)  # raises SettingsError for settings that conflict
    folder = user.lightmap_folder
    if folder.startswith("//"):
        folder = os.path.join(os.path.dirname(os.path.abspath(args.output)), folder[2:])
    folder = os.path.abspath(folder)
    for path, what in ((args.output, "output"), (args.report, "report")):
        if path and not _writable(path):
            raise CommandError(EXIT_OUTPUT, f"cannot write the {what} file: {path} (missing or read-only folder, "
                                            "or not a regular file)")
    if user.lightmaps and not _creatable(folder):
        raise CommandError(EXIT_OUTPUT, f"cannot write lightmaps into {folder} (read-only, or not a folder)")
    return folder


def _save_blend(path: str) -> None:
    """Save the baked file as a copy at ``path`` (the session keeps its own file name; relative paths are
    remapped for ``path``'s folder, which is the target's)."""
    try:
        bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    except RuntimeError as error:
        raise OSError(str(error).strip().splitlines()[-1]) from None


def _check_blend(path: str) -> None:
    """Blender reads the saved file's list of objects back (a truncated file fails: 'Missing DNA block')."""
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


def _creatable(folder: str) -> bool:
    """A folder we may write into, or one we may create (as Blender creates a render output's folders): its
    nearest existing ancestor is a folder we may write to."""
    while not os.path.exists(folder):
        parent = os.path.dirname(folder)
        if parent == folder:
            return False
        folder = parent
    return os.path.isdir(folder) and os.access(folder, os.W_OK)


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
