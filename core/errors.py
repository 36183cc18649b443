"""The errors a bake raises on purpose, one hierarchy: the command line maps each kind to its exit code, the panel
shows the message. Every message names the object, material, light, image file or setting at fault and prints
plain numbers.
"""


class BakeError(Exception):
    """A bake that cannot go on; nothing has been written."""


class SettingsError(BakeError, ValueError):
    """A setting outside its documented range (command line: exit 2)."""


class SceneError(BakeError, ValueError):
    """Bad input to the radiosity core: the scene cannot be baked as it is (command line: exit 4)."""


class OutputError(BakeError, OSError):
    """An output file cannot be written; the earlier file at that path is left as it was (command line: exit 5)."""


class BakeCancelled(BakeError):
    """Raised inside the core when ``cancelled()`` returned True, or on an interrupt; nothing has been written."""
