# Run by Blender: blender -b --factory-startup --python blender_live_check.py -- ADDON_DIR URL
# Follows the stream with the add-on's headless run() until, right after applying a list,
# GET /lights serves that same frame; then compares the scene with it: one sun per light
# (the lamps of ids no longer listed removed), each sun's +Z on the light's direction within
# 1e-4 rad, strength max(rgb) within 1e-3 relative, colour rgb / max(rgb); the world's
# environment image equal to the list's SH9 radiance at its pixels' directions.
# Prints "blender_live: ..." and exits 1 on a mismatch.
import json
import math
import sys
import urllib.request

import bpy
import mathutils

addon_dir, url = sys.argv[sys.argv.index("--") + 1:]
sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, addon_dir)
import lightprobe_live as live  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
ids_seen = set()
applied = [0]
served = {}


def fetch_lights():
    with urllib.request.urlopen(url + "/lights", timeout=10) as r:
        return json.loads(r.read())


def on_list(listing):
    applied[0] += 1
    ids_seen.update(str(light["id"]) for light in listing["lights"])
    if applied[0] < 12:  # a few lists first, so that lamps are created, updated and removed
        return False
    now = fetch_lights()
    if now["frame"] == listing["frame"]:
        served["list"] = now
        return True
    return False


last = live.run(url, frames=200, on_list=on_list)
if "list" not in served:
    print(f"blender_live: never applied the frame /lights served, in {applied[0]} lists")
    sys.exit(1)
want = served["list"]
scene = bpy.context.scene
bpy.context.view_layer.update()  # matrix_world follows the rotations set
suns = live.lamps(scene)
problems = []
if scene.get("lightprobe_frame") != str(want["frame"]):
    problems.append(f"scene at frame {scene.get('lightprobe_frame')}, /lights at {want['frame']}")
if len(suns) != len(want["lights"]):
    problems.append(f"{len(suns)} suns for {len(want['lights'])} lights")
others = [o for o in bpy.data.objects if o.type == "LIGHT" and live.ID_PROP not in o]
if others:
    problems.append(f"{len(others)} lamps the link did not make")
worst_angle = worst_strength = worst_colour = 0.0
for light in want["lights"]:
    obj = suns.get(str(light["id"]))
    if obj is None or obj.data.type != "SUN":
        problems.append(f"no sun for light {light['id']}")
        continue
    d = mathutils.Vector(light["direction"]).normalized()
    towards = (obj.matrix_world.to_3x3() @ mathutils.Vector((0.0, 0.0, 1.0))).normalized()
    worst_angle = max(worst_angle, math.atan2(towards.cross(d).length, towards.dot(d)))
    peak = max(light["rgb"])
    worst_strength = max(worst_strength, abs(obj.data.energy - peak) / peak)
    worst_colour = max(worst_colour, max(abs(c - v / peak) for c, v in zip(obj.data.color, light["rgb"])))
if worst_angle > 1e-4 or worst_strength > 1e-3 or worst_colour > 1e-4:
    problems.append(f"worst angle {worst_angle:.2e} rad, strength {worst_strength:.2e}, colour {worst_colour:.2e}")

# The world: the environment image is the SH9's radiance (clamped at 0) where Blender looks.
coefficients = want["sh9"]["coefficients"]
image = bpy.data.images[live.WORLD_IMAGE]
width, height = image.size
pixels = list(image.pixels)
worst_world = 0.0
peak_world = max(max(live.sh9_radiance(coefficients, live.world_pixel_direction(i, j, width, height)))
                 for j in range(height) for i in range(width))
for j in range(0, height, 3):
    for i in range(0, width, 5):
        expect = live.sh9_radiance(coefficients, live.world_pixel_direction(i, j, width, height))
        got = pixels[4 * (j * width + i):4 * (j * width + i) + 3]
        worst_world = max(worst_world, max(abs(g - max(0.0, e)) for g, e in zip(got, expect)) / peak_world)
# The top row is a small ring around the zenith (2.8 deg off it): its mean is the SH at +Z.
zenith = max(0.0, live.sh9_radiance(coefficients, (0.0, 0.0, 1.0))[1])
top = sum(pixels[4 * ((height - 1) * width + i) + 1] for i in range(width)) / width
if worst_world > 1e-5 or abs(top - zenith) > 0.01 * peak_world:
    problems.append(f"world image off the SH9 by {worst_world:.2e} of its peak; top row {top:.4g}, SH at +Z {zenith:.4g}")
if scene.world is None or scene.world.node_tree.nodes.get("lightprobe sh9").image != image:
    problems.append("the world does not use the SH9 image")
removed = len(ids_seen) - len(suns)
if removed <= 0:
    problems.append(f"no id went away in {applied[0]} lists ({len(ids_seen)} ids): removal untested")
print(f"blender_live: frame {want['frame']} after {applied[0]} lists: {len(suns)} suns for {len(want['lights'])} lights "
      f"({removed} lamps of {len(ids_seen)} ids seen removed), worst angle {worst_angle:.2e} rad, "
      f"worst strength {worst_strength:.2e} (relative), worst colour {worst_colour:.2e}, "
      f"world {worst_world:.2e} of its peak")
for p in problems:
    print(f"blender_live: FAILED: {p}")
sys.exit(1 if problems else 0)
