# Run by Blender: blender -b --factory-startup --python blender_check.py -- FILE.glb LIGHTS.json
# Imports the glTF with Blender's own importer and compares its sun lamps with lightprobe's
# light list: the same count, each light's direction (Blender is z-up like our world frame)
# within 0.01 deg, strength = max(rgb) W/m^2 (lux / 683) and colour = rgb / max(rgb).
# Prints one line "blender: N suns, worst angle A deg, worst strength S, worst colour C" and
# exits 1 on a mismatch.
import json
import math
import sys

import bpy
import mathutils

glb, lights_path = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=glb)
suns = [o for o in bpy.context.scene.objects if o.type == "LIGHT" and o.data.type == "SUN"]
listing = json.load(open(lights_path))
lights = listing["lights"]
per_watt = 1.0 if listing["units"] == "radiance" else 1.0 / 683.0
imported = []
for o in suns:
    towards = (o.matrix_world.to_3x3() @ mathutils.Vector((0.0, 0.0, 1.0))).normalized()  # a sun shines along -Z
    imported.append((towards, o.data.energy, tuple(o.data.color)))
ok = len(imported) == len(lights)
worst_angle = worst_strength = worst_colour = 0.0
for light in lights:
    d = mathutils.Vector(light["direction"]).normalized()
    towards, energy, colour = max(imported, key=lambda t: t[0].dot(d))
    # atan2 of |cross| and dot: Blender's vectors are float32, where acos of a dot of 1 - 1e-7 reads 0.03 deg
    worst_angle = max(worst_angle, math.degrees(math.atan2(towards.cross(d).length, towards.dot(d))))
    peak = max(light["rgb"])
    want = peak * per_watt
    worst_strength = max(worst_strength, abs(energy - want) / want)
    worst_colour = max(worst_colour, max(abs(c - v / peak) for c, v in zip(colour, light["rgb"])))
print(f"blender: {len(imported)} suns for {len(lights)} lights, worst angle {worst_angle:.2e} deg, "
      f"worst strength {worst_strength:.2e} (relative), worst colour {worst_colour:.2e}")
ok = ok and worst_angle < 0.01 and worst_strength < 1e-4 and worst_colour < 1e-4
sys.exit(0 if ok else 1)
