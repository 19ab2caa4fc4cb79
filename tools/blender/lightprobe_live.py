# lightprobe live link for Blender: the lights of a running `lightprobe stream` (or
# `merge`) as sun lamps, and its SH9 ambient as the world, updated as the lists come.
#
# Connects to GET /lights/stream?format=ndjson (one light list per line,
# ../shared/CONVENTIONS.md). Each light becomes a sun lamp named "lightprobe.<id>" in the
# collection "lightprobe live", created the first time its id is seen, updated after, and
# removed when a list no longer has it:
#   - direction: the list's world frame is z-up like Blender's, so the lamp's +Z axis is
#     turned onto the light's direction (a sun shines along its -Z, from the light into
#     the scene);
#   - strength and colour: a light's rgb is the irradiance it gives a surface facing it,
#     W/m^2 per channel for a calibrated list ("units": "radiance"), and a Blender sun's
#     strength is the irradiance it gives in W/m^2; so strength = max(rgb) and colour =
#     rgb / max(rgb), as docs/exporters.md converts for glTF and as Blender's own glTF
#     importer gets it. A "relative" list has no scale: it is applied the same way times
#     the Scale setting, with a warning (once per connection);
#   - the world: a list's "sh9" (SH9 of radiance, content "map") becomes a 64 x 32 float
#     environment image of the SH's radiance (negative lobes clamped to 0) behind a
#     Background node of strength 1, so that a uniform sky of radiance L gives a surface
#     pi L, in the suns' units. A list without sh9 leaves the world alone.
#
# In the UI: Properties > World > "lightprobe live": URL, token, scale, Connect. A thread
# reads the stream (reconnecting with backoff) and keeps the newest list; a timer applies
# it on Blender's main thread, so a slow scene never backs the stream up (lists in
# between are skipped, not queued). Headless (no thread, no timer):
#   blender -b --python lightprobe_live.py -- --url http://127.0.0.1:8080 --frames 20
# or, from a script, `import lightprobe_live; lightprobe_live.run(url, frames=20)`.
# Python standard library only (http.client).

bl_info = {
    "name": "lightprobe live link",
    "author": "lightprobe",
    "version": (1, 0, 0),
    "blender": (3, 4, 0),
    "location": "Properties > World > lightprobe live",
    "description": "Sun lamps and SH ambient from a running lightprobe stream",
    "category": "Lighting",
}

import http.client
import json
import math
import os
import sys
import threading
import time
import urllib.parse

try:
    import bpy
    import mathutils
except ImportError:  # the stream reader and the SH maths work without Blender
    bpy = None
    mathutils = None

COLLECTION = "lightprobe live"
PREFIX = "lightprobe."
ID_PROP = "lightprobe_id"  # a string: ids (HEALPix nodes) exceed Blender's 32-bit int properties
WORLD_IMAGE = "lightprobe sh9"
WORLD_SIZE = (64, 32)


def log(message):
    print("lightprobe live: " + message, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------------------
# The stream


class ListStream:
    """NDJSON light lists from GET /lights/stream?format=ndjson, one dict per next()."""

    def __init__(self, url, token=None, timeout=10.0):
        parts = urllib.parse.urlsplit(url if "://" in url else "http://" + url)
        if parts.scheme not in ("http", "https"):
            raise ValueError(f"{url}: expected an http:// or https:// URL")
        cls = http.client.HTTPSConnection if parts.scheme == "https" else http.client.HTTPConnection
        self.connection = cls(parts.hostname, parts.port, timeout=timeout)
        base = parts.path.rstrip("/")
        headers = {"Accept": "application/x-ndjson"}
        if token:
            headers["Authorization"] = "Bearer " + token
        self.connection.request("GET", base + "/lights/stream?format=ndjson", headers=headers)
        self.response = self.connection.getresponse()
        if self.response.status != 200:
            body = self.response.read(300).decode("utf-8", "replace").strip()
            self.connection.close()
            raise ConnectionError(f"{url}/lights/stream answered {self.response.status}: {body}")

    def next(self):
        """The next list, or None when the server ended the stream."""
        while True:
            line = self.response.readline()
            if not line:
                return None
            line = line.strip()
            if line:
                return json.loads(line)

    def close(self):
        self.connection.close()


# ---------------------------------------------------------------------------------------
# Units and SH (no Blender needed)


def sun_strength_and_colour(light, scale=1.0):
    """Blender sun strength (W/m^2) and colour of one light: max(rgb), rgb / max(rgb)."""
    rgb = [float(v) for v in light["rgb"]]
    peak = max(rgb)
    if not peak > 0:
        return 0.0, (1.0, 1.0, 1.0)
    return peak * scale, tuple(v / peak for v in rgb)


def sh9_basis(x, y, z):
    """Ramamoorthi-Hanrahan's real SH basis in core/spherical_harmonics.h's order."""
    return (
        0.282095,
        0.488603 * y,
        0.488603 * z,
        0.488603 * x,
        1.092548 * x * y,
        1.092548 * y * z,
        0.315392 * (3 * z * z - 1),
        1.092548 * x * z,
        0.546274 * (x * x - y * y),
    )


def sh9_radiance(coefficients, direction):
    """Radiance (r, g, b) the SH9 gives towards a unit direction."""
    basis = sh9_basis(*direction)
    return tuple(sum(b * c[k] for b, c in zip(basis, coefficients)) for k in range(3))


def world_pixel_direction(i, j, width, height):
    """The direction of pixel (column i, row j counted from the bottom, as Blender stores
    images) of an equirectangular environment texture: Cycles and EEVEE map a direction to
    u = 0.5 - atan2(y, x) / 2 pi, v = 1 - theta / pi (the image's centre faces +X, its top
    row is the zenith)."""
    u, v = (i + 0.5) / width, (j + 0.5) / height
    phi, theta = math.pi - 2 * math.pi * u, math.pi * (1 - v)
    return (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))


# ---------------------------------------------------------------------------------------
# The scene


def _collection(scene):
    coll = bpy.data.collections.get(COLLECTION)
    if coll is None:
        coll = bpy.data.collections.new(COLLECTION)
    if coll.name not in scene.collection.children:
        scene.collection.children.link(coll)
    return coll


def lamps(scene=None):
    """{id (str): object} of the suns the link made."""
    coll = bpy.data.collections.get(COLLECTION)
    if coll is None:
        return {}
    return {o[ID_PROP]: o for o in coll.objects if ID_PROP in o}


def _new_sun(coll, light_id):
    data = bpy.data.lights.new(PREFIX + light_id, type="SUN")
    data.angle = 0.0  # a directional light: the list's region is in its solid angle, not here
    obj = bpy.data.objects.new(PREFIX + light_id, data)
    obj[ID_PROP] = light_id
    obj.rotation_mode = "QUATERNION"
    coll.objects.link(obj)
    return obj


def _remove(obj):
    data = obj.data
    bpy.data.objects.remove(obj, do_unlink=True)
    if data is not None and data.users == 0:
        bpy.data.lights.remove(data)


def set_world_from_sh9(scene, coefficients, scale=1.0):
    """The scene's world lit by the SH9's radiance (an environment image built from it)."""
    world = scene.world
    if world is None:
        world = scene.world = bpy.data.worlds.new("lightprobe")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    background = nodes.get("lightprobe background") or nodes.new("ShaderNodeBackground")
    background.name = "lightprobe background"
    background.inputs["Strength"].default_value = 1.0
    texture = nodes.get("lightprobe sh9") or nodes.new("ShaderNodeTexEnvironment")
    texture.name = "lightprobe sh9"
    width, height = WORLD_SIZE
    image = bpy.data.images.get(WORLD_IMAGE)
    if image is None or tuple(image.size) != (width, height):
        image = bpy.data.images.new(WORLD_IMAGE, width, height, alpha=False, float_buffer=True)
        image.colorspace_settings.name = "Non-Color"  # radiance, not an encoded colour
    texture.image = image
    output = next((n for n in nodes if n.type == "OUTPUT_WORLD"), None) or nodes.new("ShaderNodeOutputWorld")
    links.new(texture.outputs["Color"], background.inputs["Color"])
    links.new(background.outputs["Background"], output.inputs["Surface"])
    pixels = []
    for j in range(height):
        for i in range(width):
            r, g, b = sh9_radiance(coefficients, world_pixel_direction(i, j, width, height))
            pixels += (max(0.0, r) * scale, max(0.0, g) * scale, max(0.0, b) * scale, 1.0)
    image.pixels.foreach_set(pixels)
    image.update()
    world["lightprobe_sh9"] = [float(v) for row in coefficients for v in row]
    return world


class Applier:
    """Applies lists to a scene; warns once about relative units."""

    def __init__(self, scale=1.0):
        self.scale = scale
        self.warned = False
        self.frame = None

    def apply(self, listing, scene=None):
        scene = scene or bpy.context.scene
        if listing.get("frame_convention", "z-up") != "z-up":
            raise ValueError(f"frame_convention {listing.get('frame_convention')!r}: expected z-up")
        if listing.get("units") != "radiance" and not self.warned:
            log(f"the lists are in {listing.get('units')!r} units, not calibrated: sun strength = max(rgb) x "
                f"scale {self.scale:g}, not W/m^2 (calibrate with `lightprobe calib photometric`)")
            self.warned = True
        coll = _collection(scene)
        existing = lamps(scene)
        seen = set()
        for light in listing.get("lights", []):
            light_id = str(light["id"])
            seen.add(light_id)
            obj = existing.get(light_id) or _new_sun(coll, light_id)
            d = mathutils.Vector(light["direction"]).normalized()
            obj.rotation_quaternion = d.to_track_quat("Z", "Y")  # the lamp's +Z onto the light's direction
            strength, colour = sun_strength_and_colour(light, self.scale)
            obj.data.energy = strength
            obj.data.color = colour
        for light_id, obj in existing.items():
            if light_id not in seen:
                _remove(obj)
        sh = listing.get("sh9")
        if sh and sh.get("order") == 2:
            set_world_from_sh9(scene, sh["coefficients"], self.scale)
        self.frame = listing.get("frame")
        scene["lightprobe_frame"] = str(self.frame)
        return self.frame


def run(url, frames=10, token=None, scale=1.0, timeout=30.0, on_list=None):
    """Headless: applies the next `frames` lists of the stream to the current scene, on the
    calling thread, and returns the last list applied. `on_list(listing)` (optional) runs
    after each; returning True stops early."""
    applier = Applier(scale)
    stream = ListStream(url, token, timeout)
    last = None
    try:
        for _ in range(frames):
            listing = stream.next()
            if listing is None:
                break
            applier.apply(listing)
            last = listing
            if on_list and on_list(listing):
                break
    finally:
        stream.close()
    return last


# ---------------------------------------------------------------------------------------
# In the UI: a reader thread and a timer


class LiveLink:
    """Reads the stream on a thread, keeps only the newest list; poll() applies it."""

    def __init__(self, url, token=None, scale=1.0):
        self.url, self.token = url, token
        self.applier = Applier(scale)
        self.lock = threading.Lock()
        self.latest = None
        self.status = "connecting"
        self.quit = threading.Event()
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self):
        backoff = 0.5
        while not self.quit.is_set():
            try:
                stream = ListStream(self.url, self.token, timeout=10)
                self.status = "connected"
                backoff = 0.5
                while not self.quit.is_set():
                    listing = stream.next()
                    if listing is None:
                        break
                    with self.lock:
                        self.latest = listing
                stream.close()
                self.status = "stream ended; reconnecting"
            except Exception as e:  # the server away, a timeout: try again, slower each time
                self.status = f"{e}; retrying in {backoff:g} s"
            self.quit.wait(backoff)
            backoff = min(backoff * 2, 10.0)

    def poll(self, scene):
        with self.lock:
            listing, self.latest = self.latest, None
        if listing is not None:
            self.applier.apply(listing, scene)

    def stop(self):
        self.quit.set()


_link = None


def _timer():
    if _link is None:
        return None
    try:
        _link.poll(bpy.context.scene)
    except Exception as e:
        _link.status = f"could not apply a list: {e}"
    return 0.05  # 20 Hz at most: the stream's rate


if bpy is not None:

    class LightprobeLiveSettings(bpy.types.PropertyGroup):
        url: bpy.props.StringProperty(name="URL", default="http://127.0.0.1:8080")
        token: bpy.props.StringProperty(name="Token", subtype="PASSWORD", description="Bearer token, if the server has one")
        scale: bpy.props.FloatProperty(name="Scale", default=1.0, min=0.0,
                                       description="Multiplies strengths and the world (needed for relative lists)")

    class LIGHTPROBE_OT_live_connect(bpy.types.Operator):
        bl_idname = "lightprobe.live_connect"
        bl_label = "Connect"
        bl_description = "Follow the lights of a running lightprobe stream"

        def execute(self, context):
            global _link
            s = context.scene.lightprobe_live
            if _link:
                _link.stop()
            _link = LiveLink(s.url, s.token or None, s.scale)
            if not bpy.app.timers.is_registered(_timer):
                bpy.app.timers.register(_timer, first_interval=0.1)
            return {"FINISHED"}

    class LIGHTPROBE_OT_live_disconnect(bpy.types.Operator):
        bl_idname = "lightprobe.live_disconnect"
        bl_label = "Disconnect"

        def execute(self, context):
            global _link
            if _link:
                _link.stop()
            _link = None
            return {"FINISHED"}

    class LIGHTPROBE_PT_live(bpy.types.Panel):
        bl_label = "lightprobe live"
        bl_space_type = "PROPERTIES"
        bl_region_type = "WINDOW"
        bl_context = "world"

        def draw(self, context):
            s = context.scene.lightprobe_live
            self.layout.prop(s, "url")
            self.layout.prop(s, "token")
            self.layout.prop(s, "scale")
            row = self.layout.row()
            row.operator("lightprobe.live_connect")
            row.operator("lightprobe.live_disconnect")
            if _link:
                frame = _link.applier.frame
                self.layout.label(text=f"{_link.status}, frame {frame if frame is not None else '-'}, "
                                       f"{len(lamps())} suns")

    _classes = (LightprobeLiveSettings, LIGHTPROBE_OT_live_connect, LIGHTPROBE_OT_live_disconnect, LIGHTPROBE_PT_live)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.lightprobe_live = bpy.props.PointerProperty(type=LightprobeLiveSettings)


def unregister():
    global _link
    if _link:
        _link.stop()
        _link = None
    if bpy.app.timers.is_registered(_timer):
        bpy.app.timers.unregister(_timer)
    del bpy.types.Scene.lightprobe_live
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)


def _main(argv):
    import argparse

    p = argparse.ArgumentParser(prog="lightprobe_live.py", description="Apply lists of a lightprobe stream, headless")
    p.add_argument("--url", required=True)
    p.add_argument("--frames", type=int, default=10)
    p.add_argument("--token")
    p.add_argument("--scale", type=float, default=1.0)
    p.add_argument("--save", help="write the .blend here afterwards")
    a = p.parse_args(argv)
    last = run(a.url, a.frames, a.token, a.scale)
    log(f"applied up to frame {last['frame'] if last else '-'}: {len(lamps())} suns")
    if a.save:
        image = bpy.data.images.get(WORLD_IMAGE)
        if image is not None:
            image.file_format = "OPEN_EXR"  # float pixels, packed into the .blend
            image.pack()
        # Blender takes only absolute paths here ("lit.blend" raised, and nothing was saved).
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(a.save))


if __name__ == "__main__" and bpy is not None and "--" in sys.argv:
    # Blender prints an exception from a --python script and exits 0: a script driving it
    # headless would take a failed run (nothing applied, nothing saved) for a good one.
    try:
        _main(sys.argv[sys.argv.index("--") + 1:])
    except SystemExit:
        raise
    except Exception as e:  # noqa: BLE001 - any failure is one line and exit 1
        print(f"lightprobe_live: {e}", file=sys.stderr)
        sys.exit(1)
