"""Peak resident memory per stage of one command-line bake, against the estimate its report gives.

    .venv/bin/python benchmarks/memory_stages.py IN.blend [--quality draft|medium|high] [--target lightmap]
        [--folder DIR]

The bake runs as a child process (``python -m radiosity_addon bake``), as a user would run it. Its resident memory
is sampled every SAMPLE_S seconds (/proc/PID/statm, Linux) and each sample is put in the stage that the last
progress line on stderr names (numbers removed), so that a table shows which stage holds the peak. The last row
is the child's own peak (ru_maxrss, which no sampling misses) beside the estimate and the limit from the report
(core/memory.py). All sizes in GiB.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SAMPLE_S = 0.2
GIB = 2 ** 30


def staged_peaks(command: list[str]) -> tuple[dict[str, int], int]:
    """(stage -> peak sampled resident bytes, in the order the stages began; the child's ru_maxrss in bytes)."""
    child = subprocess.Popen(command, cwd=ROOT, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    peaks, stage, lines = {"opening and export": 0}, ["opening and export"], []

    def follow_progress():
        for line in child.stderr:
            lines.append(line)
            if line.startswith("[radiosity] "):
                stage[0] = re.sub(r"\d[\d.,]*", "#", line[12:].strip())[:60]
                peaks.setdefault(stage[0], 0)
    reader = threading.Thread(target=follow_progress, daemon=True)
    reader.start()
    page = os.sysconf("SC_PAGE_SIZE")
    while True:
        pid, status, usage = os.wait4(child.pid, os.WNOHANG)  # reaped here, for its ru_maxrss
        if pid:
            break
        try:
            with open(f"/proc/{child.pid}/statm", encoding="ascii") as handle:
                resident = int(handle.read().split()[1]) * page
        except (OSError, ValueError, IndexError):
            resident = 0
        peaks[stage[0]] = max(peaks[stage[0]], resident)
        time.sleep(SAMPLE_S)
    reader.join()
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{' '.join(command)} failed:\n{''.join(lines[-20:])}")
    return peaks, usage.ru_maxrss * 1024  # Linux reports kilobytes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="the .blend file to bake")
    parser.add_argument("--quality", default="medium")
    parser.add_argument("--target", default="lightmap")
    parser.add_argument("--folder", help="where the bake goes (default: a new temporary folder)")
    args = parser.parse_args()
    folder = Path(args.folder or tempfile.mkdtemp())
    folder.mkdir(parents=True, exist_ok=True)
    report_file = folder / f"{Path(args.scene).stem}_{args.quality}.json"
    command = [sys.executable, "-m", "radiosity_addon", "bake", args.scene, "-o",
               str(folder / f"{Path(args.scene).stem}_{args.quality}.blend"), "--report", str(report_file),
               "--quality", args.quality, "--target", args.target, "--lightmap-dir", str(folder)]
    peaks, maximum = staged_peaks(command)
    memory = json.loads(report_file.read_text())["memory"]
    print(f"{Path(args.scene).name} at {args.quality}, {args.target}: peak resident GiB per stage "
          f"(sampled every {SAMPLE_S} s)")
    for stage, peak in peaks.items():
        if peak:
            print(f"{peak / GIB:8.2f}  {stage}")
    print(f"{maximum / GIB:8.2f}  peak (ru_maxrss); estimate {memory['estimated_gb']:.2f}, limit "
          f"{memory['limit_gb']:.1f}, estimate / peak {memory['estimated_gb'] * GIB / maximum:.2f}")


if __name__ == "__main__":
    main()
