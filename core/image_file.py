"""Lightmap files through OpenImageIO (which Blender ships): OpenEXR (half or full float, scene-linear, with
metadata) and a low-dynamic-range PNG with a documented encoding.

PNG encoding ("exposure + sRGB"): value = srgb_oetf(clamp(light x 2^exposure, 0, 1)), 8 bits; decode with the
sRGB transfer function then divide by 2^exposure. Images are (height, width, channels) with row 0 at the bottom
(Blender's order); files store the top row first, so rows are flipped on the way out. A non-finite value never
reaches a file, nor a value a half-float EXR cannot hold (above HALF_MAX: write 32-bit floats instead).
"""
from __future__ import annotations

import numpy as np
import OpenImageIO as oiio

from .errors import OutputError

HALF_MAX = 65504.0  # the largest finite half float (IEEE 754 binary16)


def write_exr(path: str, light: np.ndarray, half: bool = True, metadata: dict[str, str] | None = None) -> None:
    """Write (h, w, 3) scene-linear light as an RGB OpenEXR (zip compression, no time stamps: identical inputs
    give identical files). Raises OutputError for non-finite light, or light above HALF_MAX with ``half``."""
    _check_finite(path, light)
    if half and float(np.max(light, initial=0.0)) > HALF_MAX:
        raise OutputError(f"Cannot write '{path}' as half floats: its light reaches {float(np.max(light)):.4g}, "
                          f"above {HALF_MAX:g}; write 32-bit floats.")
    pixels = np.ascontiguousarray(light[::-1], dtype=np.float32)
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], "half" if half else "float")
    spec.attribute("compression", "zip")
    spec.attribute("DateTime", "")  # OpenImageIO stamps the time otherwise; a bake must be byte-reproducible
    for key, value in (metadata or {}).items():
        spec.attribute(key, str(value))
    _write(path, spec, pixels)


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """sRGB transfer function (IEC 61966-2-1) of values in [0, 1]."""
    return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)


def write_png(path: str, light: np.ndarray, exposure_stops: float = 0.0,
              metadata: dict[str, str] | None = None) -> None:
    """Write (h, w, 3) light as an 8-bit sRGB PNG after scaling by 2^exposure (see the module docstring)."""
    _check_finite(path, light)
    if not np.isfinite(exposure_stops):
        raise OutputError(f"Cannot write '{path}': the exposure must be a finite number of stops, "
                          f"got {exposure_stops}.")
    scaled = np.clip(light[::-1] * 2.0 ** exposure_stops, 0.0, 1.0)
    pixels = np.ascontiguousarray(np.round(srgb_encode(scaled) * 255.0), dtype=np.uint8)
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], "uint8")
    for key, value in (metadata or {}).items():
        spec.attribute(key, str(value))
    _write(path, spec, pixels)


def read_image(path: str) -> np.ndarray:
    """(h, w, c) float32 pixels of an image file, row 0 at the bottom (for checks, tests and benchmarks)."""
    source = oiio.ImageInput.open(path)
    if source is None:
        raise OutputError(f"Cannot read image '{path}': {oiio.geterror()}")
    try:
        pixels = source.read_image(format="float")
        if pixels is None:
            raise OutputError(f"Cannot read image '{path}': {source.geterror() or 'incomplete file'}")
    finally:
        source.close()
    return np.asarray(pixels)[::-1]


def check_image(path: str, light: np.ndarray) -> None:
    """Raise OutputError unless the image file at ``path`` reads back whole, with ``light``'s size and finite
    pixels (the check of a staged file before it replaces its target)."""
    pixels = read_image(path)
    if pixels.shape[:2] != light.shape[:2] or not np.isfinite(pixels).all():
        raise OutputError(f"The image written to '{path}' does not read back as written.")


def _check_finite(path: str, light: np.ndarray) -> None:
    if not np.isfinite(light).all():
        raise OutputError(f"Refusing to write '{path}': the light has {int((~np.isfinite(light)).sum())} "
                          "non-finite values.")


def _write(path: str, spec, pixels: np.ndarray) -> None:
    out = oiio.ImageOutput.create(path)
    if out is None or not out.open(path, spec):
        message = oiio.geterror() or (out.geterror() if out is not None else "")
        raise OutputError(f"Cannot write the lightmap file '{path}': {message.strip() or 'unknown error'}")
    try:
        written = out.write_image(pixels)
    finally:
        closed = out.close()
    if not (written and closed):
        raise OutputError(f"Cannot write the lightmap file '{path}': {out.geterror().strip() or 'write failed'}")
