"""--help for the scripts that run inside Blender (`blender -b --python SCRIPT -- SPEC.json`):
answered from the script's docstring before bpy is imported or anything runs, so that it works
under python3 too (tests/py_scripts_help.py). No bpy here."""
import os
import sys


def exit_on_help(doc, path, args="SPEC.json"):
    """--help or -h (after "--" under Blender, or as usual under python3): prints the usage (the
    script's arguments after "--": `args`) and `doc`, and ends the process with status 0."""
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    if {"-h", "--help"} & set(argv):
        print("usage: blender -b --factory-startup --python %s -- %s\n\n%s"
              % ("scripts/" + os.path.basename(path), args, doc))
        sys.exit(0)
