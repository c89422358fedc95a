# What dfb's Blender scripts share: failing with a status the shell sees, and importing a glTF
# file into an empty scene with Blender's stock importer.
import os

import bpy
import numpy

# Debian's Blender 3.4 glTF importer still spells numpy's bool `np.bool`, an alias NumPy 1.24
# (Debian 12's) removed: give it back so that the stock importer runs unchanged.
if not hasattr(numpy, "bool"):
    numpy.bool = bool


def fail(message):
    print("DFB_ERROR " + message, flush=True)
    # sys.exit inside `blender -b --python` is caught by Blender, which then exits 0; os._exit
    # gives the shell the status.
    os._exit(1)


def import_gltf(path):
    """Empties the scene (the factory cube, camera and light would count as imported) and imports
    `path` with the importer's default options (lighting mode 'Standard'); fails naming why."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    try:
        result = bpy.ops.import_scene.gltf(filepath=path)
    except Exception as e:  # RuntimeError from the operator, ImportError without numpy
        fail("cannot import the scene %s: %s" % (path, e))
    if "FINISHED" not in result:
        fail("cannot import the scene %s (%s)" % (path, result))
