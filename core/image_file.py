"""Lightmap files through OpenImageIO (which Blender ships): OpenEXR (half or full float, scene-linear, with
metadata) and a low-dynamic-range PNG with a documented encoding.

PNG encoding ("exposure + sRGB"): value = srgb_oetf(clamp(light x 2^exposure, 0, 1)), 8 bits; decode with the
sRGB transfer function then divide by 2^exposure. Images are (height, width, channels) with row 0 at the bottom
(Blender's order); files store the top row first, so rows are flipped on the way out.
"""
from __future__ import annotations

import numpy as np

from .scene import SceneError


def _oiio():
    try:
        import OpenImageIO
    except ImportError as error:  # Blender ships it; a bare Python needs `pip install OpenImageIO`
        raise SceneError("OpenImageIO is not available to write lightmap files "
                         "(Blender ships it; in a plain Python: pip install OpenImageIO).") from error
    return OpenImageIO


def write_exr(path: str, light: np.ndarray, half: bool = True, metadata: dict[str, str] | None = None) -> None:
    """Write (h, w, 3) scene-linear light as an RGB OpenEXR (zip compression, no time stamps: identical inputs
    give identical files)."""
    oiio = _oiio()
    pixels = np.ascontiguousarray(light[::-1], dtype=np.float32)
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], "half" if half else "float")
    spec.attribute("compression", "zip")
    spec.attribute("DateTime", "")  # OpenImageIO stamps the time otherwise; a bake must be byte-reproducible
    for key, value in (metadata or {}).items():
        spec.attribute(key, str(value))
    _write(oiio, path, spec, pixels)


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """sRGB transfer function (IEC 61966-2-1) of values in [0, 1]."""
    return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)


def write_png(path: str, light: np.ndarray, exposure_stops: float = 0.0,
              metadata: dict[str, str] | None = None) -> None:
    """Write (h, w, 3) light as an 8-bit sRGB PNG after scaling by 2^exposure (see the module docstring)."""
    oiio = _oiio()
    scaled = np.clip(light[::-1] * 2.0 ** exposure_stops, 0.0, 1.0)
    pixels = np.ascontiguousarray(np.round(srgb_encode(scaled) * 255.0), dtype=np.uint8)
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], "uint8")
    for key, value in (metadata or {}).items():
        spec.attribute(key, str(value))
    _write(oiio, path, spec, pixels)


def read_image(path: str) -> np.ndarray:
    """(h, w, c) float32 pixels of an image file, row 0 at the bottom (for tests and benchmarks)."""
    oiio = _oiio()
    source = oiio.ImageInput.open(path)
    if source is None:
        raise SceneError(f"Cannot read image '{path}': {oiio.geterror()}")
    try:
        pixels = source.read_image(format="float")
    finally:
        source.close()
    return np.asarray(pixels)[::-1]


def _write(oiio, path: str, spec, pixels: np.ndarray) -> None:
    out = oiio.ImageOutput.create(path)
    if out is None or not out.open(path, spec):
        message = oiio.geterror() or (out.geterror() if out is not None else "")
        raise SceneError(f"Cannot write the lightmap file '{path}': {message.strip() or 'unknown error'}")
    try:
        if not out.write_image(pixels):
            raise SceneError(f"Cannot write the lightmap file '{path}': {out.geterror()}")
    finally:
        out.close()
