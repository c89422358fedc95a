# What Blender's stock glTF importer makes of a file: the lights it created, in Blender's units and
# frame and converted back to glTF's, for the import test (tests/integration/blender_import_test.cpp,
# issue 19 point 7). Run headless:
#   blender -b --factory-startup --python server/blender/dfb_inspect_gltf.py -- FILE.glb OUT.json
# Exits 0 with OUT.json written, or 1 with a line "DFB_ERROR ..." on stdout.
import json
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dfb_blender import fail, import_gltf  # noqa: E402 (beside this script, not on Blender's path)


def to_gltf(v):
    # The importer turns glTF's Y-up into Blender's Z-up: glTF (x, y, z) = Blender (x, z, -y).
    return [v[0], v[2], -v[1]]


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 2:
        fail("usage: blender -b --python dfb_inspect_gltf.py -- FILE.glb OUT.json")
    source, out = argv
    import_gltf(source)
    lights = []
    for obj in bpy.data.objects:
        if obj.type != "LIGHT":
            continue
        m = obj.matrix_world
        location = [m[0][3], m[1][3], m[2][3]]
        # A Blender light, like a glTF one, shines along its local -Z.
        direction = [-m[0][2], -m[1][2], -m[2][2]]
        data = obj.data
        light = {"name": obj.name, "type": data.type, "energy": data.energy, "color": list(data.color),
                 "location": location, "direction": direction,
                 "gltf_location": to_gltf(location), "gltf_direction": to_gltf(direction)}
        if data.type == "SPOT":
            light["spot_size"] = data.spot_size
            light["spot_blend"] = data.spot_blend
        lights.append(light)
    report = {"blender": bpy.app.version_string, "lights": lights,
              "cameras": [o.name for o in bpy.data.objects if o.type == "CAMERA"],
              "meshes": sum(1 for o in bpy.data.objects if o.type == "MESH")}
    with open(out, "w") as f:
        json.dump(report, f, indent=1)


main()
