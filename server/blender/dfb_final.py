# A final render of a dfb shot in Cycles (issue 19 point 8): the session's scene as the server
# exports it, the shot's camera and the rig's lights converted one by one, rendered headless on
# the CPU into a linear EXR. Run:
#   blender -b --factory-startup --python server/blender/dfb_final.py -- JOB.json
# The job's fields and the light conversions are in server/blender/README.md. Prints
# "DFB_NOTE <text>" for what is not rendered exactly, "DFB_DONE <output>" when the EXR is written,
# "DFB_ERROR <text>" and exits 1 on failure. Cycles' own status lines carry "Sample N/M".
import json
import math
import os
import sys

import bpy
from mathutils import Matrix, Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dfb_blender import fail, import_gltf  # noqa: E402 (beside this script, not on Blender's path)

MAX_SIZE = 8192
MAX_SAMPLES = 65536
# glTF is Y-up, Blender Z-up; the importer maps glTF (x, y, z) to Blender (x, -z, y).
GLTF_TO_BLENDER = Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1)))


def note(message):
    print("DFB_NOTE " + message, flush=True)


def vec(v):
    return Vector((v[0], -v[2], v[1]))


def number(job, key, lo, hi, integer=False):
    v = job.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and not isinstance(v, int)) or not lo <= v <= hi:
        fail("job field '%s': expected %s in [%s, %s], got %r" % (key, "an integer" if integer else "a number", lo, hi, v))
    return v


def frame_towards(direction, roll_deg=0.0):
    # The product's light frame (docs/lighting.md "Area light"): right = normalize(n x up),
    # up' = right x n with up = +Y (+X near vertical), turned by roll about n; in glTF axes.
    n = Vector(direction).normalized()
    up = Vector((0, 1, 0)) if abs(n.y) < 0.999 else Vector((1, 0, 0))
    right = n.cross(up).normalized()
    upp = right.cross(n)
    r = math.radians(roll_deg)
    right, upp = right * math.cos(r) + upp * math.sin(r), upp * math.cos(r) - right * math.sin(r)
    # Blender lights shine down local -Z; local X is the width, local Y the height.
    m = Matrix.Identity(4)
    for row in range(3):
        m[row][0], m[row][1], m[row][2] = right[row], upp[row], -n[row]
    return m


def place(obj, light):
    m = frame_towards(light.get("direction", [0, -1, 0]), light.get("roll", 0.0))
    p = light.get("position", [0, 0, 0])
    m[0][3], m[1][3], m[2][3] = p[0], p[1], p[2]
    obj.matrix_world = GLTF_TO_BLENDER @ m


def add_light(name, kind, light):
    data = bpy.data.lights.new(name=name, type=kind)
    c = light.get("color", [1, 1, 1])
    data.color = (c[0], c[1], c[2])
    data.cycles.cast_shadow = bool(light.get("shadow", True))
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    place(obj, light)
    return data


def spot(name, light):
    # Candela -> W: Cycles' point and spot lights radiate power/(4 pi) W/sr; the preview's numbers
    # are taken as radiometric (no 683 lm/W), so a Lambert surface reads the same in both.
    data = add_light(name, "SPOT", light)
    data.energy = 4 * math.pi * light["intensity"]
    data.shadow_soft_size = 0.0
    outer = math.radians(light["coneAngle"])
    inner = max(outer - math.radians(light.get("penumbra", 0.0)), 0.0)
    data.spot_size = 2 * outer
    # Cycles: smoothstep((cos t - cos outer) / ((1 - cos outer) blend)); the preview (KHR
    # reference): smoothstep over [cos outer, cos inner]; equal when the widths in cosine match.
    data.spot_blend = min((math.cos(inner) - math.cos(outer)) / max(1 - math.cos(outer), 1e-9), 1.0)
    if any(a < 90 for a in light.get("barnDoors", [90, 90, 90, 90])):
        note("light %s: barn doors are not rendered" % name)
    if light.get("cookie"):
        note("light %s: its cookie is not rendered" % name)


def point(name, light):
    data = add_light(name, "POINT", light)
    data.energy = 4 * math.pi * light["intensity"]
    data.shadow_soft_size = 0.0


def sun(name, light):
    data = add_light(name, "SUN", light)
    data.energy = light["intensity"]  # lux -> W/m^2, as for the punctual lights
    data.angle = 0.0


def area(name, light):
    # Radiance Le (nits) -> W: a one-sided Cycles area light of power P has radiance P / (4 A)
    # (measured: P = pi Le A renders pi / 4 dark against the preview on the table).
    data = add_light(name, "AREA", light)
    w, h = light.get("size", [1, 1])
    if light.get("shape") == "disk":
        data.shape, data.size = "DISK", w
        a = math.pi * w * w / 4
    else:
        data.shape, data.size, data.size_y = "RECTANGLE", w, h
        a = w * h
    data.energy = 4 * light["intensity"] * a
    if light.get("pattern"):
        note("light %s: its pattern is not rendered" % name)


# Rig type -> (conversion, what it stands in for: None when exact).
CONVERSIONS = {
    "spot": (spot, None),
    "bendy": (spot, "a BendyLight, rendered as its unbent spot"),
    "point": (point, None),
    "directional": (sun, None),
    "area": (area, None),
    "bentArea": (area, "a bent area light, rendered as its unbent panel"),
}


def environment(lights, assets, nodes, links, world_out):
    # Every environment adds: one Background per light, summed by Add Shader nodes.
    shader = None
    for light in lights:
        bg = nodes.new("ShaderNodeBackground")
        c = light.get("color", [1, 1, 1])
        bg.inputs["Strength"].default_value = light.get("intensity", 1.0)
        if light.get("map"):
            path = os.path.join(assets, light["map"])
            try:
                image = bpy.data.images.load(path, check_existing=True)
            except RuntimeError as e:
                fail("light %s: cannot read the map %s: %s" % (light["name"], light["map"], e))
            image.colorspace_settings.name = "Linear"
            tex = nodes.new("ShaderNodeTexEnvironment")
            tex.image = image
            # The preview's map direction (Environment.h: u = 0.5 + atan2(x, -z) / 2 pi, v = acos(y)
            # / pi from the top, world = Ry(yaw) Rx(pitch) Rz(roll) map) in Blender's world:
            # direction d looks up map direction R^-1 d; Cycles' u is the preview's minus a quarter
            # turn about +Z, which the lookup rotation adds.
            yaw, pitch, roll = (math.radians(a) for a in light.get("rotation", [0, 0, 0]))
            r = Matrix.Rotation(yaw, 3, "Y") @ Matrix.Rotation(pitch, 3, "X") @ Matrix.Rotation(roll, 3, "Z")
            c3 = GLTF_TO_BLENDER.to_3x3()
            lookup = Matrix.Rotation(-math.pi / 2, 3, "Z") @ c3 @ r.transposed() @ c3.transposed()
            coords = nodes.new("ShaderNodeTexCoord")
            mapping = nodes.new("ShaderNodeMapping")
            mapping.vector_type = "VECTOR"
            mapping.inputs["Rotation"].default_value = lookup.to_euler("XYZ")
            links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
            links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
            mix = nodes.new("ShaderNodeMixRGB")
            mix.blend_type = "MULTIPLY"
            mix.inputs["Fac"].default_value = 1.0
            mix.inputs["Color2"].default_value = (c[0], c[1], c[2], 1)
            links.new(tex.outputs["Color"], mix.inputs["Color1"])
            links.new(mix.outputs["Color"], bg.inputs["Color"])
        else:
            bg.inputs["Color"].default_value = (c[0], c[1], c[2], 1)
        if shader is None:
            shader = bg.outputs["Background"]
        else:
            add = nodes.new("ShaderNodeAddShader")
            links.new(shader, add.inputs[0])
            links.new(bg.outputs["Background"], add.inputs[1])
            shader = add.outputs["Shader"]
    if shader is not None:
        links.new(shader, world_out.inputs["Surface"])
    return shader is not None


def camera(scene, cam, width, height):
    data = bpy.data.cameras.new("dfb_shot")
    obj = bpy.data.objects.new("dfb_shot", data)
    scene.collection.objects.link(obj)
    w2c = Matrix([[cam["worldToCamera"][c * 4 + r] for c in range(4)] for r in range(4)])  # column-major
    obj.matrix_world = GLTF_TO_BLENDER @ w2c.inverted()
    data.sensor_fit = "VERTICAL"
    if cam.get("orthographic"):
        data.type = "ORTHO"
        data.ortho_scale = 2 * cam["ymag"] * max(width / height, 1.0)
    else:
        data.angle_y = cam["yfov"]
    data.clip_start, data.clip_end = cam["near"], cam["far"]
    scene.camera = obj


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 1:
        fail("usage: blender -b --python dfb_final.py -- JOB.json")
    try:
        with open(argv[0]) as f:
            job = json.load(f)
    except (OSError, ValueError) as e:
        fail("cannot read the job %s: %s" % (argv[0], e))
    if job.get("format") != 1:
        fail("job field 'format': expected 1")
    width = number(job, "width", 1, MAX_SIZE, True)
    height = number(job, "height", 1, MAX_SIZE, True)
    samples = number(job, "samples", 1, MAX_SAMPLES, True)
    threads = number(job, "threads", 0, 1024, True) if "threads" in job else 0
    for key in ("scene", "output", "assetDirectory"):
        if not isinstance(job.get(key), str):
            fail("job field '%s': expected a path" % key)
    if not isinstance(job.get("camera"), dict) or not isinstance(job.get("rig"), dict):
        fail("job fields 'camera' and 'rig': expected objects")

    import_gltf(job["scene"])
    # The file's lights are the rig's as KHR_lights_punctual stand-ins: the rig below is exact.
    for obj in [o for o in bpy.data.objects if o.type in ("LIGHT", "CAMERA")]:
        bpy.data.objects.remove(obj)

    scene = bpy.context.scene
    camera(scene, job["camera"], width, height)
    envs = []
    for light in job["rig"].get("lights", []):
        name, kind = light.get("name", "?"), light.get("type")
        if not light.get("enabled", True):
            continue
        if light.get("include") or light.get("exclude"):
            note("light %s: light linking is not rendered (Blender 3.4 has none): it lights everything" % name)
        if kind == "environment":
            envs.append(light)
        elif kind in CONVERSIONS:
            convert, stand_in = CONVERSIONS[kind]
            if stand_in:
                note("light %s: %s" % (name, stand_in))
            convert(name, light)
        else:
            note("light %s: type %s is not rendered" % (name, kind))

    world = bpy.data.worlds.new("dfb_world")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputWorld")
    if not environment(envs, job["assetDirectory"], nodes, links, out):
        black = nodes.new("ShaderNodeBackground")
        black.inputs["Strength"].default_value = 0.0
        links.new(black.outputs["Background"], out.inputs["Surface"])
    scene.world = world

    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = samples
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = int(job.get("seed", 0))
    # A box filter one pixel wide: the bake's samples are box-filtered too.
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    if job.get("directOnly"):
        # Bounces count after the first hit: 0 leaves light -> surface -> camera, the preview's terms.
        cy.max_bounces = 0
        cy.caustics_reflective = cy.caustics_refractive = False
    scene.render.threads_mode = "FIXED" if threads else "AUTO"
    if threads:
        scene.render.threads = threads
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True  # alpha = coverage; the background is not seen, as in the preview
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_mode = "RGBA"
    settings.color_depth = "32"
    settings.exr_codec = "ZIP"
    scene.render.filepath = job["output"]
    try:
        bpy.ops.render.render(write_still=True)
    except RuntimeError as e:
        fail("Cycles failed: %s" % e)
    if not os.path.exists(job["output"]):
        fail("Cycles wrote no image to %s" % job["output"])
    print("DFB_DONE " + job["output"], flush=True)


main()
