"""The add-on's modules that need only numpy and math (eevee_dome.py, ground_edge.py), loaded
from their files outside Blender: the package's __init__ imports bpy."""
import importlib.util
import os

SRC = os.environ.get("ENVL_SOURCE_DIR") or os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))


def load(name):
    """plugin/envlight_addon/NAME.py as a module of its own."""
    spec = importlib.util.spec_from_file_location(
        name, os.path.join(SRC, "plugin", "envlight_addon", name + ".py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
