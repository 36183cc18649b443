"""``python -m radiosity_addon bake IN.blend -o OUT.blend ...`` with the bpy module.

The add-on imports the core relatively (``from ..core``), as it must inside an installed extension, so the
repository root is loaded here as the package ``radiosity_baker`` and the add-on is registered from it.
"""
import importlib.util
import os
import sys
from pathlib import Path


def load_package(name: str = "radiosity_baker"):
    """Import the repository root (the extension's root) as a package."""
    if name in sys.modules:
        return sys.modules[name]
    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location(name, root / "__init__.py", submodule_search_locations=[str(root)])
    package = importlib.util.module_from_spec(spec)
    sys.modules[name] = package
    spec.loader.exec_module(package)
    return package


def main(argv: list[str]) -> int:
    if not argv or argv[0] != "bake":
        print("usage: python -m radiosity_addon bake IN.blend -o OUT.blend [options]  (--help for options)",
              file=sys.stderr)
        return 2
    package = load_package()
    import bpy  # noqa: F401  (the bpy module must be importable)
    if not hasattr(bpy.types.Scene, "radiosity"):
        package.register()
    from radiosity_baker.radiosity_addon import cli
    try:
        return cli.run(argv[1:], prog="python -m radiosity_addon bake")
    except SystemExit as exit_:
        return int(exit_.code or 0)


if __name__ == "__main__":
    code = main(sys.argv[1:])
    # The bpy 4.2 module can crash while tearing down at interpreter exit (seen as SIGSEGV after a successful
    # bake); everything is written and flushed by now, so leave without the teardown.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
