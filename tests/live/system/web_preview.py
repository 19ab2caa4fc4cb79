"""The live page's 3D preview in headless Chromium, against a running `lightprobe stream`
that replays two maps in turn (made here: a sky with a small bright sun at azimuth -20 deg,
then at 200 deg, 35 deg up). For each sun the script waits until the page has rendered a
list whose lights point at that sun, screenshots the diffuse sphere, and checks in the
pixels that its lit side is on the sun's side: the camera looks along +Y with +X to the
right, so a sun at -20 deg lights the right half and one at 200 deg the left. Then it
screenshots the whole page (the operator's view) and checks it was filled in.

  web_preview.py maps DIR                 writes DIR/000.pfm, DIR/001.pfm
  web_preview.py check CHROMIUM URL WORK [SCREENSHOT_DIR]
Exit 0 pass, 1 fail (one line saying why), 77 when the server has no three.js."""
import math
import os
import struct
import sys
import urllib.error
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from page_driver import Browser, BrowserError, decode_png  # noqa: E402

SUNS = (-20.0, 200.0)  # azimuths (deg) of the two maps' suns, CONVENTIONS.md: from +X towards +Y
SUN_ELEVATION = 35.0


def write_maps(folder, width=128, height=64):
    """Two latlong PFM maps: a bluish sky, a grey ground and a sun 5 degrees across holding most of the power."""
    os.makedirs(folder, exist_ok=True)
    for index, azimuth in enumerate(SUNS):
        a, e = math.radians(azimuth), math.radians(SUN_ELEVATION)
        sun = (math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e))
        rows = []
        for v in range(height):
            theta = math.pi * (v + 0.5) / height
            row = []
            for u in range(width):
                phi = 2 * math.pi * (u + 0.5) / width
                d = (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
                if sum(x * y for x, y in zip(d, sun)) > math.cos(math.radians(5)):
                    row += [400.0, 380.0, 340.0]
                elif d[2] > 0:
                    row += [0.15, 0.2, 0.3]
                else:
                    row += [0.08, 0.08, 0.08]
            rows.append(row)
        with open(os.path.join(folder, "%03d.pfm" % index), "wb") as f:
            f.write(b"PF\n%d %d\n-1.0\n" % (width, height))
            for row in reversed(rows):  # PFM stores the bottom row first
                f.write(struct.pack("<%df" % len(row), *row))


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


# 8-bit sRGB code -> linear value, so that the statistics measure light, not the encoding.
LINEAR = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in (v / 255 for v in range(256))]


def lit_side(png):
    """Where the light falls on the sphere in a square screenshot of it: the luminance-weighted
    mean of x (-1 left edge, +1 right edge) over the disc, and the right half's mean
    luminance over the left half's."""
    w, h, ch, px = decode_png(png)
    cx, cy, r = w / 2, h / 2, 0.9 * min(w, h) / 2
    total = moment = left = right = 0.0
    for y in range(h):
        for x in range(w):
            dx, dy = x + 0.5 - cx, y + 0.5 - cy
            if dx * dx + dy * dy > r * r:
                continue
            i = (y * w + x) * ch
            lum = 0.2126 * LINEAR[px[i]] + 0.7152 * LINEAR[px[i + 1]] + 0.0722 * LINEAR[px[i + 2]]
            total += lum
            moment += lum * dx / r
            if dx < 0:
                left += lum
            else:
                right += lum
    if total <= 0:
        fail("the sphere is black in the screenshot")
    return moment / total, right / max(left, 1e-9)


def check(chromium, url, work, shots):
    base = url.split("#")[0]
    try:
        urllib.request.urlopen(base + "three/three.module.js", timeout=30).read()
    except urllib.error.HTTPError as err:
        if err.code == 404:
            print("SKIP: this lightprobe was built without three.js", file=sys.stderr)
            sys.exit(77)
        raise
    browser = Browser(chromium, os.path.join(work, "profile"), log_path=os.path.join(work, "chromium.log"))
    try:
        browser.navigate(url)
        # A notice instead of the preview is a failure here: the server does have three.js.
        browser.wait_for("window.lpPreview && (lpPreview.ready || document.getElementById('scene-note')"
                         ".textContent.startsWith('3D preview off'))", timeout=60)
        if not browser.evaluate("lpPreview.ready"):
            fail("page says: " + browser.evaluate("document.getElementById('scene-note').textContent"))
        results = []
        for azimuth in SUNS:
            # The rendered frame's lights must point at this sun (their power-weighted mean
            # direction, within 10 deg of its azimuth); the
            # screenshot counts only if the page rendered nothing else meanwhile.
            want = ("lpPreview.renderedFrame !== null && lpPreview.keyDirection && (() => {"
                    " const k = lpPreview.keyAzimuthDeg(); const d = ((k - (%g)) %% 360 + 540) %% 360 - 180;"
                    " return Math.abs(d) < 10 && lpPreview.renderedFrame + 1; })()" % azimuth)
            for _ in range(20):
                frame = browser.wait_for(want, timeout=60) - 1
                s = browser.evaluate("lpPreview.sphereOnScreen()")
                png = browser.screenshot((s["x"] - s["r"], s["y"] - s["r"], 2 * s["r"], 2 * s["r"]))
                if browser.evaluate("lpPreview.renderedFrame") == frame:
                    break
            else:
                fail("the page never held a frame of the sun at %g deg long enough to screenshot it" % azimuth)
            key = browser.evaluate("lpPreview.keyAzimuthDeg()")
            centroid, ratio = lit_side(png)
            results.append((azimuth, frame, key, centroid, ratio))
            print("web_preview: sun at %6.1f deg (frame %d, mean light direction at %.1f deg): lit centroid x = %+.3f of the "
                  "radius, right/left luminance %.2f" % (azimuth, frame, key, centroid, ratio))
            if shots:
                with open(os.path.join(shots, "sphere_sun_%d.png" % int(azimuth)), "wb") as f:
                    f.write(png)
        (_, _, _, c_right, r_right), (_, _, _, c_left, r_left) = results
        # A sun at -20 deg (+X, a little towards the camera) lights the right half, one at 200 deg the left.
        if not (c_right > 0.1 and r_right > 1.5):
            fail("sun at -20 deg (right): centroid %+.3f, right/left %.2f; expected > +0.1 and > 1.5" % (c_right, r_right))
        if not (c_left < -0.1 and r_left < 1 / 1.5):
            fail("sun at 200 deg (left): centroid %+.3f, right/left %.2f; expected < -0.1 and < 0.67" % (c_left, r_left))
        # The operator's view: labels over the probe, the stage sparklines, the camera line.
        browser.wait_for("document.querySelectorAll('#sparks .spark polyline').length >= 2 && "
                         "document.getElementById('probe').src.startsWith('blob:')", timeout=60)
        state = browser.evaluate("({labels: [...document.querySelectorAll('#marks text')].map((e) =>"
                                 " e.firstChild.textContent).join(',').split(',').map(Number).sort((a, b) => a - b).join(','),"
                                 " sparks: [...document.querySelectorAll('#sparks .spark')].map((e) => e.dataset.stage),"
                                 " camera: document.getElementById('camera').textContent,"
                                 " rows: document.querySelectorAll('#rows tr').length})")
        print("web_preview: operator view: ranks %s over the probe, sparklines %s, camera '%s', %d table rows"
              % (state["labels"], ",".join(state["sparks"]), state["camera"], state["rows"]))
        if state["labels"] != "1,2,3,4,5,6,7,8":
            fail("the probe's labels rank '%s', expected the 8 strongest once each" % state["labels"])
        if not state["camera"].startswith("streaming"):
            fail("camera line says '%s', expected streaming" % state["camera"])
        if "sample" not in state["sparks"] or "capture->list" not in state["sparks"]:
            fail("no sparkline for the sample stage and the latency: %s" % state["sparks"])
        if shots:
            with open(os.path.join(shots, "operator_page.png"), "wb") as f:
                f.write(browser.screenshot())
    except BrowserError as err:
        fail(str(err))
    finally:
        browser.close()


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "maps":
        write_maps(sys.argv[2])
    elif len(sys.argv) in (5, 6) and sys.argv[1] == "check":
        check(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5] if len(sys.argv) == 6 else None)
    else:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
