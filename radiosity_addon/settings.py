"""Every setting a user can choose, once: name, type (from the default), default, bounds, unit and help text.

What is made from this table (no bpy here):
- the Blender properties of Render properties > Radiosity (properties.py), and that panel's rows, in table order
  (panels.py);
- the command line's options (cli.py), with the bounds as argparse ranges;
- ``UserSettings``, the frozen record the bake reads (job.py, presets.py), built by keyword from either.

Adding a setting is one entry here plus its use in the bake.
"""
from __future__ import annotations

from dataclasses import dataclass, field, make_dataclass
from typing import Callable

from ..core.errors import SettingsError
from .presets import PRESETS


@dataclass(frozen=True)
class Setting:
    """name: the property's and UserSettings' field; flag: the command-line option ("" for none); low / high: hard
    bounds (the panel's min / max, the command line's range); soft_high: where the panel's slider ends; unit:
    "LENGTH" shows metres in the scene's units; items: (identifier, label, description) of an enum; negate: the
    flag sets a True-by-default switch to False; subtype: Blender's string subtype (DIR_PATH). The panel draws the
    settings in table order: those of a ``section`` ("vertex_colors", "lightmap") only when the target writes it,
    and greyed out where ``enabled_when(settings)`` is False."""

    name: str
    label: str
    default: object
    help: str
    flag: str = ""
    low: float | None = None
    high: float | None = None
    soft_high: float | None = None
    unit: str = ""
    items: tuple[tuple[str, str, str], ...] = ()
    negate: bool = False
    subtype: str = ""
    precision: int | None = None
    section: str = ""
    enabled_when: Callable[[object], bool] | None = None

    @property
    def kind(self) -> type:
        return type(self.default)


def _quality_items() -> tuple[tuple[str, str, str], ...]:
    presets = tuple((name, name.title(), preset.summary()) for name, preset in PRESETS.items())
    return presets + (("CUSTOM", "Custom", "Use the settings below"),)


def _custom(settings) -> bool:
    return settings.quality == "CUSTOM"


SETTINGS = (
    Setting("quality", "Quality", "MEDIUM", "Preset for element size, convergence and lightmap density, scaled "
            "to the scene's size; Custom uses the settings below", flag="--quality",
            items=_quality_items()),
    Setting("element_size", "Element Size", 0.25, "Target edge length of the receiving elements, m (Custom "
            "quality)", flag="--element-size", low=1e-3, high=1e3, soft_high=2.0, unit="LENGTH", enabled_when=_custom),
    Setting("patch_size", "Patch Size", 1.0, "Target edge length of the shooting patches, m; larger is faster "
            "(Custom quality)", flag="--patch-size", low=1e-3, high=1e3, soft_high=5.0, unit="LENGTH",
            enabled_when=_custom),
    Setting("adaptive_passes", "Adaptive Passes", 0, "Passes that make elements finer where the direct light "
            "changes fast (shadow edges), each at most doubling them (Custom quality)", flag="--adaptive-passes",
            low=0, high=8, enabled_when=_custom),
    Setting("residual", "Convergence", 0.01, "Stop when the light still changing is this share of the injected "
            "power and of most surfaces' own light (Custom quality)", flag="--residual", low=1e-6, high=1.0,
            precision=4, enabled_when=_custom),
    Setting("light_samples", "Light Samples", 4, "Shadow rays per element and soft light: this number squared "
            "(Custom quality)", flag="--light-samples", low=1, high=64, soft_high=16, enabled_when=_custom),
    Setting("seed", "Seed", 0, "Seed of the stratified samples: a bake is the same for the same seed",
            flag="--seed", low=0, high=2 ** 31 - 1),
    Setting("max_memory_gb", "Memory Limit (GB)", 0.0, "The most memory a bake may use, GiB: a larger bake gets "
            "coarser elements or is refused before the heavy work starts; 0 allows 75% of this machine's memory",
            flag="--max-memory-gb", low=0.0, high=float(1 << 20), soft_high=256.0),
    Setting("target", "Target", "VERTEX_COLORS", "What the bake writes", flag="--target", items=(
        ("VERTEX_COLORS", "Vertex Colors", "A colour attribute per mesh corner"),
        ("LIGHTMAP", "Lightmap", "A lightmap texture on a new UV map (sharp shadows at any mesh density)"),
        ("BOTH", "Both", "Vertex colours and a lightmap"))),
    Setting("light_groups", "Light Groups", False, "Also write the light of each light group (View Layer > Light "
            "Groups, set on lamps, emissive objects and the world) apart: lightmap pages and colour attributes named "
            "after the group ('ungrouped' for the rest); the main result is their sum", flag="--light-groups"),
    Setting("relight_cache", "Relighting Cache", "", "Also write the bake split by light source into this file "
            "(// is the .blend's folder), so that Update Light (--relight) applies later changes of lamps' "
            "strength and colour (lamps that are off included), emission strengths, the world's strength and "
            "light groups without baking again; empty writes none", flag="--cache", subtype="FILE_PATH"),
    Setting("attribute_name", "Attribute", "Radiosity", "Name of the colour attribute the bake writes (replaced "
            "on rebake)", flag="--attribute", section="vertex_colors"),
    Setting("vertex_domain", "Domain", "CORNER", "What the colour attribute holds a colour for",
            flag="--vertex-domain", section="vertex_colors", items=(
                ("CORNER", "Face Corner", "One colour per face corner: creases stay sharp"),
                ("POINT", "Vertex", "One colour per vertex, the mean of its corners (as Cycles bakes into a "
                                    "vertex attribute), for engines and exporters that want one"))),
    Setting("vertex_indirect", "Indirect Light", "auto", "How colour attributes get indirect light",
            flag="--vertex-indirect", section="vertex_colors", items=(
                ("auto", "Automatic", "Final gather at corners where surfaces lie close by (creases, contacts), "
                                      "interpolation elsewhere"),
                ("gather", "Final Gather", "Rays from each corner look up the radiosity solution: the corner's own "
                                           "light, also in a room's corners; noisier on open surfaces"),
                ("interpolate", "Interpolate", "From the radiosity elements around the corner: fast, smooth; too "
                                               "bright in concave corners"))),
    Setting("vertex_gather_samples", "Corner Gather Samples", 16, "Final-gather rays per corner: this number "
            "squared (Custom quality; corners of one vertex with one normal share them)",
            flag="--vertex-gather-samples", low=1, high=64, soft_high=32, section="vertex_colors",
            enabled_when=lambda settings: _custom(settings) and settings.vertex_indirect != "interpolate"),
    Setting("own_mesh_copies", "Copies Get Own Mesh", True, "Give each baked object that shares its mesh with "
            "another (linked duplicates) its own copy of the mesh, as Make Single User > Object Data does, so that "
            "each holds its own light (Undo reverses it); off, they share the first one's colours",
            flag="--keep-shared-meshes", negate=True, section="vertex_colors"),
    Setting("texels_per_metre", "Texels per Metre", 0.0, "Lightmap density; 0 follows the quality preset "
            "(Medium: 256 texels across the scene), or the resolution when one is set",
            flag="--texels-per-meter", low=0.0, high=1e4, soft_high=1024.0, section="lightmap",
            enabled_when=lambda settings: not settings.lightmap_resolution),
    Setting("lightmap_resolution", "Resolution", 0, "Square lightmap size in texels that the density is chosen to "
            "fill; 0 sizes the pages from the density", flag="--resolution", low=0, high=16384, section="lightmap",
            enabled_when=lambda settings: not settings.texels_per_metre),
    Setting("lightmap_max_size", "Max Size", 4096, "Texels a side of a lightmap image; a density that needs more "
            "gets several images", flag="--max-size", low=64, high=16384, section="lightmap"),
    Setting("lightmap_padding", "Padding", 4, "Texels between charts, filled by dilation so that filtering and "
            "mipmaps do not bleed", flag="--padding", low=1, high=64, soft_high=32, section="lightmap"),
    Setting("lightmap_indirect", "Indirect Light", "auto", "How lightmap texels get indirect light (Custom "
            "quality; the presets use Automatic)", flag="--indirect", section="lightmap", enabled_when=_custom, items=(
                ("auto", "Automatic", "Final gather where the elements are coarse next to the distances between "
                                      "surfaces, else interpolation"),
                ("interpolate", "Interpolate", "From the radiosity elements' corners: smooth, fast (texels "
                                               "facing a surface nearer than an element still gather)"),
                ("gather", "Final Gather", "Rays from each texel look up the radiosity solution: finer indirect "
                                           "detail, some noise"))),
    Setting("gather_samples", "Gather Samples", 8, "Final-gather rays per texel: this number squared (Custom "
            "quality)", flag="--gather-samples", low=1, high=64, soft_high=32, section="lightmap",
            enabled_when=_custom),
    Setting("lightmap_uv_map", "UV Map", "Lightmap", "Name of the UV map the bake makes, or reads with Use "
            "Existing UV Map (existing UV maps are never changed)", flag="--uv-map", section="lightmap"),
    Setting("lightmap_existing_uv", "Use Existing UV Map", False, "Bake onto the lightmap UV map of that name, "
            "which the objects already have (it is read, not changed), instead of making one",
            flag="--existing-uv-map", section="lightmap"),
    Setting("lightmap_image", "Image", "Radiosity Lightmap", "Name of the lightmap image and of its .exr file",
            flag="--lightmap-image", section="lightmap"),
    Setting("lightmap_folder", "Folder", "//", "Where the .exr goes, made if missing (// is the saved .blend's "
            "folder; an unsaved .blend gets the image packed)", flag="--lightmap-dir", subtype="DIR_PATH", section="lightmap"),
    Setting("lightmap_half", "Half Float", True, "16-bit float EXR (smaller); off for 32-bit float",
            flag="--float", negate=True, section="lightmap"),
    Setting("lightmap_png", "Also PNG", False, "Also write an 8-bit sRGB PNG beside the EXR, for engines that "
            "want low dynamic range (not for a packed image)", flag="--png", section="lightmap"),
    Setting("lightmap_png_exposure", "PNG Exposure", 0.0, "Stops: the PNG holds sRGB(clamp(light x 2^stops, 0, "
            "1)); on the command line, giving it also writes the PNG", flag="--png-exposure", low=-64.0,
            high=64.0, soft_high=10.0, section="lightmap", enabled_when=lambda settings: settings.lightmap_png),
    Setting("create_radiosity_mesh", "Create Radiosity Mesh", False, "Also add an object holding the adaptive "
            "element mesh and its light", flag="--radiosity-mesh"),
    Setting("make_local", "Make Linked Objects Local", False, "Make objects linked from libraries local (with "
            "their meshes) so that they hold their bake; off, they light the scene but are not baked",
            flag="--make-local"),
)
BY_NAME = {setting.name: setting for setting in SETTINGS}
UNGROUPED = "ungrouped"


def light_group_output(name: str, group: str) -> str:
    """The name of a light group's output: the main output's name (image, colour attribute) and the group's
    ("ungrouped" for the light of no group)."""
    return f"{name} {group or UNGROUPED}"


def _check(values) -> None:
    """SettingsError naming the first setting whose value is of the wrong type, out of bounds or not an item."""
    for setting in SETTINGS:
        value = getattr(values, setting.name)
        if not isinstance(value, setting.kind) and not (setting.kind is float and type(value) is int):
            raise SettingsError(f"Setting '{setting.name}' must be a {setting.kind.__name__}, got {value!r}.")
        if setting.items and value not in [item[0] for item in setting.items]:
            raise SettingsError(f"Setting '{setting.name}' must be one of "
                                f"{', '.join(item[0] for item in setting.items)}, got '{value}'.")
        if setting.kind in (int, float) and not (
                (setting.low is None or value >= setting.low) and (setting.high is None or value <= setting.high)):
            raise SettingsError(f"Setting '{setting.name}' must be from {setting.low:g} to {setting.high:g}, got "
                                f"{value:g}.")


UserSettings = make_dataclass(
    "UserSettings", [(setting.name, setting.kind, field(default=setting.default)) for setting in SETTINGS],
    frozen=True, namespace={
        "__doc__": "What the panel and the command line let a user choose: the fields of SETTINGS, by keyword; "
                   "raises SettingsError for a value out of its bounds.",
        "__post_init__": _check,
        "vertex_colors": property(lambda self: self.target in ("VERTEX_COLORS", "BOTH")),
        "lightmaps": property(lambda self: self.target in ("LIGHTMAP", "BOTH")),
    })
