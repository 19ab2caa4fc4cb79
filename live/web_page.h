// The light server's page (GET /): self-contained (inline CSS and JS; the only other files
// it loads are three.js' modules, served by the same server: live/web_assets.h).
//   - A live 3D preview (three.js): a diffuse sphere, a glossy knot and a ground plane lit
//     by the current list, the 4 strongest lights as directional lights with shadow maps,
//     the rest and the list's "sh9" (when present) as a THREE.LightProbe; without three.js
//     or WebGL, a one-line notice instead.
//   - The operator's view: /probe.png refreshed live (it draws every light as a disc sized
//     by power, sampling/overlay.h) with the 8 strongest numbered over it (lights within
//     ~10 deg of each other share a label), a table of the
//     brightest, the numbers of /status (fps, latency, clients, drops; with `stream`, the
//     camera's state, dropped and broken brackets and reconnects), and a sparkline per
//     stage of the mean time per bracket each second, from /metrics' histograms.
// With a token, open the page as /#token=T: the fragment never leaves the browser, and the
// page sends "Authorization: Bearer T" itself on every request, so everything with data
// goes through fetch(): JSON, the stream (Server-Sent Events read from a fetch body, since
// EventSource cannot send headers) and the picture (a blob URL, since <img src> cannot
// either). three.js is public like the page, so import() needs no header.
#pragma once

#include <string_view>

namespace lp {

inline constexpr std::string_view kWebPage = R"LPHTML(<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>lightprobe live</title>
<style>
  :root { color-scheme: dark; }
  body { margin: 0; font: 14px/1.4 system-ui, sans-serif; background: #16181c; color: #e6e6e6; }
  header { display: flex; align-items: center; gap: 12px; padding: 10px 16px; background: #202329; }
  header h1 { font-size: 16px; margin: 0; font-weight: 600; }
  #dot { width: 10px; height: 10px; border-radius: 50%; background: #a33; }
  #dot.live { background: #3a3; }
  main { padding: 12px 16px; display: grid; gap: 12px; grid-template-columns: minmax(0, 3fr) minmax(280px, 2fr); }
  @media (max-width: 900px) { main { grid-template-columns: 1fr; } }
  .numbers { display: grid; grid-template-columns: repeat(auto-fit, minmax(100px, 1fr)); gap: 8px; grid-column: 1 / -1; }
  .num { background: #202329; border-radius: 6px; padding: 6px 10px; }
  .num b { display: block; font-size: 20px; font-variant-numeric: tabular-nums; white-space: nowrap; }
  .num span { color: #9aa; font-size: 12px; }
  .num.warn b { color: #e8a33a; }
  .num b#method { font-size: 16px; line-height: 28px; overflow: hidden; text-overflow: ellipsis; }
  .card { background: #202329; border-radius: 6px; padding: 8px 10px; min-width: 0; }
  .card h2 { font-size: 13px; font-weight: 500; color: #9aa; margin: 0 0 6px; }
  #scene { position: relative; aspect-ratio: 16 / 9; background: #0e1013; border-radius: 4px; overflow: hidden; }
  #scene canvas { position: absolute; inset: 0; width: 100%; height: 100%; display: block; }
  #scene-note { position: absolute; left: 8px; bottom: 6px; color: #9aa; font-size: 12px; }
  #view { position: relative; background: #000; border-radius: 4px; overflow: hidden; aspect-ratio: 2 / 1; }
  #view img, #view svg { position: absolute; inset: 0; width: 100%; height: 100%; }
  #view img:not([src]) { visibility: hidden; }
  #view svg text { fill: #fff; font-size: 18px; font-weight: 600; paint-order: stroke; stroke: #000; stroke-width: 3px; }
  #empty { position: absolute; inset: 0; display: flex; align-items: center; justify-content: center; color: #789; }
  #camera { font-size: 13px; margin-bottom: 8px; }
  #camera b { font-weight: 600; }
  #camera .err { color: #e8a33a; display: block; overflow: hidden; text-overflow: ellipsis; white-space: nowrap; }
  .spark { display: grid; grid-template-columns: 86px minmax(0, 1fr) 64px; align-items: center; gap: 6px; }
  .spark span { color: #9aa; font-size: 12px; }
  .spark b { text-align: right; font-weight: 500; font-variant-numeric: tabular-nums; font-size: 12px; }
  .spark svg { width: 100%; height: 26px; }
  .spark polyline { fill: none; stroke: #6cb6ff; stroke-width: 1.5; vector-effect: non-scaling-stroke; }
  table { width: 100%; border-collapse: collapse; font-variant-numeric: tabular-nums; }
  th, td { text-align: right; padding: 2px 6px; border-bottom: 1px solid #2a2d33; }
  th { color: #9aa; font-weight: 500; }
  .sw { display: inline-block; width: 12px; height: 12px; border-radius: 2px; vertical-align: middle; }
  footer { color: #789; font-size: 12px; padding: 0 16px 12px; }
</style>
</head>
<body>
<header><div id="dot" title="stream"></div><h1>lightprobe live</h1><span id="conn">connecting...</span></header>
<main>
  <div class="numbers">
    <div class="num"><b id="fps">-</b><span>fps</span></div>
    <div class="num"><b id="count">-</b><span>lights</span></div>
    <div class="num"><b id="latency">-</b><span>latency (ms)</span></div>
    <div class="num"><b id="frame">-</b><span>frame</span></div>
    <div class="num"><b id="method">-</b><span>method</span></div>
    <div class="num" id="bd"><b id="brackets-dropped">-</b><span>brackets dropped</span></div>
    <div class="num" id="bb"><b id="broken">-</b><span>frames in broken brackets</span></div>
    <div class="num" id="rc"><b id="reconnects">-</b><span>camera reconnects</span></div>
    <div class="num"><b id="clients">-</b><span>stream clients</span></div>
    <div class="num"><b id="dropped">-</b><span>lists dropped</span></div>
  </div>
  <div class="card">
    <h2>3D preview: a diffuse sphere, a glossy knot and the ground, lit by the current lights</h2>
    <div id="scene"><canvas id="scene-canvas"></canvas><div id="scene-note">loading three.js...</div></div>
  </div>
  <div class="card">
    <h2>camera</h2>
    <div id="camera">-</div>
    <h2>stage times (ms, mean per bracket each second, last minute)</h2>
    <div id="sparks"><span style="color:#789">waiting for /metrics...</span></div>
  </div>
  <div class="card">
    <h2>probe: discs are the lights, sized by power; numbers rank the strongest</h2>
    <div id="view">
      <div id="empty">waiting for the first frame...</div>
      <img id="probe" alt="probe preview">
      <svg id="marks" viewBox="0 0 1000 500" preserveAspectRatio="none"></svg>
    </div>
  </div>
  <div class="card">
    <h2>strongest lights</h2>
    <table><thead><tr><th>#</th><th>id</th><th></th><th>azim&deg;</th><th>elev&deg;</th><th>lum</th><th>%</th></tr></thead>
    <tbody id="rows"></tbody></table>
  </div>
</main>
<footer>Azimuth from +X towards +Y, elevation above the horizon (+Z up). 3D preview: the 4 strongest lights as
shadowed directional lights, the rest and the list's SH9 as ambient; the camera looks along +Y, +X to the right.</footer>
<script>
"use strict";
const token = new URLSearchParams(location.hash.slice(1)).get("token");
const headers = token ? { "Authorization": "Bearer " + token } : {};
function url(path, params) {
  const u = new URL(path, location.href);
  for (const k in (params || {})) u.searchParams.set(k, params[k]);
  return u.pathname + u.search;
}
const $ = (id) => document.getElementById(id);
const SVGNS = "http://www.w3.org/2000/svg";
const LABELLED = 8;        // strongest lights numbered on the probe (the PNG draws every disc)
const SHADOWED = 4;        // strongest lights with a shadow map in the 3D preview
const lum = (c) => 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
const fmt = (v, d) => (v === null || v === undefined || !isFinite(v)) ? "-" : Number(v).toFixed(d);
function needToken() { $("dot").className = ""; $("conn").textContent = "needs a token: open /#token=..."; }
function esc(s) { return String(s).replace(/[&<>"']/g, (c) => "&#" + c.charCodeAt(0) + ";"); }

function colour(rgb) {
  const m = Math.max(rgb[0], rgb[1], rgb[2], 1e-30);
  const enc = (v) => { v = Math.max(0, Math.min(1, v / m));
    v = v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055; return Math.round(255 * v); };
  return "rgb(" + enc(rgb[0]) + "," + enc(rgb[1]) + "," + enc(rgb[2]) + ")";
}

// ---- the operator's view: numbers, labels over the probe, the table --------------------
function showList(list) {
  $("frame").textContent = list.frame;
  $("method").textContent = list.method || "-";
  $("count").textContent = list.lights.length;
  const lights = list.lights.map((l) => {
    const d = l.direction;
    let phi = Math.atan2(d[1], d[0]); if (phi < 0) phi += 2 * Math.PI;
    const theta = Math.acos(Math.max(-1, Math.min(1, d[2])));
    return { id: l.id, rgb: l.rgb, dir: d, phi: phi, theta: theta, y: lum(l.rgb) };
  });
  const total = lights.reduce((s, l) => s + Math.max(0, l.y), 0) || 1;
  lights.sort((a, b) => b.y - a.y);
  // /probe.png draws every light as a disc sized by its power (sampling/overlay.h): the
  // page only numbers the strongest, so no light is drawn twice.
  const svg = $("marks");
  while (svg.firstChild) svg.removeChild(svg.firstChild);
  // Lights closer than ~10 deg share one label ("1,2,5"), or a split sun would be a smudge.
  const groups = [];
  lights.slice(0, LABELLED).forEach((l, i) => {
    const x = l.phi / (2 * Math.PI) * 1000, y = l.theta / Math.PI * 500;
    const g = groups.find((g) => Math.hypot(g.x - x, g.y - y) < 28);
    if (g) g.ranks.push(i + 1); else groups.push({ x: x, y: y, ranks: [i + 1], share: 0 });
    (g || groups[groups.length - 1]).share += 100 * l.y / total;
  });
  for (const g of groups) {
    const label = document.createElementNS(SVGNS, "text");
    label.setAttribute("x", Math.min(900, g.x + 12)); label.setAttribute("y", Math.max(18, g.y - 9));
    label.textContent = g.ranks.join(",");
    const t = document.createElementNS(SVGNS, "title");
    t.textContent = "#" + g.ranks.join(", #") + ": " + g.share.toFixed(1) + " % of the power";
    label.appendChild(t); svg.appendChild(label);
  }
  const rows = lights.slice(0, 16).map((l, i) =>
    "<tr><td>" + (i < LABELLED ? i + 1 : "") + "</td><td>" + l.id + "</td><td><span class='sw' style='background:" +
    colour(l.rgb) + "'></span></td><td>" + fmt(l.phi * 180 / Math.PI, 1) + "</td><td>" +
    fmt(90 - l.theta * 180 / Math.PI, 1) + "</td><td>" + l.y.toPrecision(3) + "</td><td>" +
    fmt(100 * l.y / total, 1) + "</td></tr>");
  $("rows").innerHTML = rows.join("");
  refreshImage();
  try { preview.show(list, lights); } catch (err) { console.error(err); }
}

// The picture: fetched (with the token), shown through a blob URL, at most every 300 ms,
// one at a time.
let loading = false, lastLoad = 0, pending = false, shownUrl = null;
async function refreshImage() {
  const now = Date.now();
  if (loading || now - lastLoad < 300) { pending = true; return; }
  loading = true; pending = false; lastLoad = now;
  try {
    // "no-cache": the browser revalidates with the ETag; an unchanged picture costs a 304.
    const r = await fetch(url("/probe.png"), { headers: headers, cache: "no-cache" });
    if (r.status === 401) needToken();
    if (r.ok) {
      const next = URL.createObjectURL(await r.blob());
      $("probe").src = next; $("empty").style.display = "none";
      if (shownUrl) URL.revokeObjectURL(shownUrl);
      shownUrl = next;
    }
  } catch (err) { /* the server is away; the next list tries again */ }
  loading = false;
  if (pending) setTimeout(refreshImage, 300);
}

// Server-Sent Events read from a fetch() body: events end with a blank line, their data
// lines start with "data: ".
let reconnects = 0;
async function connect() {
  try {
    const r = await fetch(url("/lights/stream"), { headers: headers, cache: "no-store" });
    if (r.status === 401) { needToken(); setTimeout(connect, 5000); return; }
    if (!r.ok || !r.body) throw new Error("stream answered " + r.status);
    $("dot").className = "live"; $("conn").textContent = reconnects ? "live (reconnected " + reconnects + "x)" : "live";
    const reader = r.body.getReader(), decoder = new TextDecoder();
    let buffer = "";
    for (;;) {
      const { value, done } = await reader.read();
      if (done) break;
      buffer += decoder.decode(value, { stream: true });
      let end;
      while ((end = buffer.indexOf("\n\n")) >= 0) {
        const event = buffer.slice(0, end); buffer = buffer.slice(end + 2);
        const data = event.split("\n").filter((l) => l.startsWith("data: ")).map((l) => l.slice(6)).join("\n");
        if (data) { try { showList(JSON.parse(data)); } catch (err) { console.error(err); } }
      }
    }
  } catch (err) { /* reconnect below */ }
  reconnects++;
  $("dot").className = ""; $("conn").textContent = "reconnecting...";
  setTimeout(connect, 1000);
}

function setWarn(box, id, value) {
  $(id).textContent = value === undefined || value === null ? "-" : value;
  $(box).className = "num" + (value > 0 ? " warn" : "");
}

async function pollStatus() {
  try {
    const r = await fetch(url("/status"), { headers: headers, cache: "no-cache" });
    if (r.ok) {
      const s = await r.json();
      $("fps").textContent = fmt(s.fps, 1);
      const ms = s.latency_seconds === null ? null : 1000 * s.latency_seconds;
      $("latency").textContent = fmt(ms, ms < 10 ? 1 : 0);
      $("clients").textContent = s.stream_clients;
      $("dropped").textContent = s.stream_lists_dropped;
      if (s.frame !== null && $("frame").textContent === "-") { $("frame").textContent = s.frame; refreshImage(); }
      showCamera(s);
    } else if (r.status === 401) {
      needToken();
    }
  } catch (err) { /* the server is away; try again */ }
  setTimeout(pollStatus, 1000);
}

// `stream` adds a "pipeline" section (the camera and its brackets), `merge` a "merge" one.
function showCamera(s) {
  const p = s.pipeline, m = s.merge;
  if (p) {
    setWarn("bd", "brackets-dropped", p.brackets_dropped);
    setWarn("bb", "broken", p.frames_dropped_partial);
    setWarn("rc", "reconnects", p.reconnects);
    $("camera").innerHTML = "<b>" + esc(p.camera_state) + "</b> &middot; " + esc(p.source) + " &middot; " +
      p.frames_in + " frames in, " + p.brackets_processed + " brackets processed" +
      (p.last_error ? "<span class='err' title='" + esc(p.last_error) + "'>last error: " + esc(p.last_error) + "</span>" : "");
  } else if (m) {
    const used = (m.inputs || []).filter((i) => i.state === "used").length;
    $("camera").innerHTML = "<b>merge</b> of " + used + " / " + (m.inputs || []).length + " inputs used" +
      (m.inputs || []).map((i) => "<span class='err'>" + esc(i.url) + ": " + esc(i.state) +
        (i.reason ? " (" + esc(i.reason) + ")" : "") + "</span>").join("");
  }
}

// Per-stage times from /metrics: the histograms' _sum and _count, differenced between polls,
// give the mean time per bracket over each second (not the last bracket's alone).
const sparks = new Map();  // name -> { last: [sum, count], points: [ms or null] }
const SPARK_POINTS = 60;
function parseMetrics(text) {
  const out = new Map();
  const re = /^lightprobe_(stage_duration|latency)_seconds_(sum|count)(?:\{stage="([a-z_]+)"\})? (\S+)$/gm;
  let m;
  while ((m = re.exec(text))) {
    const name = m[1] === "latency" ? "capture->list" : m[3];
    const e = out.get(name) || [0, 0];
    e[m[2] === "sum" ? 0 : 1] = Number(m[4]);
    out.set(name, e);
  }
  return out;
}
function drawSparks() {
  const rows = [];
  for (const [name, s] of sparks) {
    const pts = s.points, vals = pts.filter((v) => v !== null);
    if (!vals.length) continue;
    const top = Math.max(...vals) * 1.15 || 1;
    const line = pts.map((v, i) => v === null ? null : (i * 100 / (SPARK_POINTS - 1)).toFixed(1) + "," +
      (25 - 23 * v / top).toFixed(1)).filter((p) => p).join(" ");
    const last = vals[vals.length - 1];
    rows.push("<div class='spark' data-stage='" + esc(name) + "'><span>" + esc(name) + "</span>" +
      "<svg viewBox='0 0 100 26' preserveAspectRatio='none'><polyline points='" + line + "'/></svg><b>" +
      (last < 10 ? last.toFixed(2) : last.toFixed(1)) + "</b></div>");
  }
  if (rows.length) $("sparks").innerHTML = rows.join("");
}
async function pollMetrics() {
  try {
    const r = await fetch(url("/metrics"), { headers: headers, cache: "no-store" });
    if (r.ok) {
      const now = parseMetrics(await r.text());
      for (const [name, [sum, count]] of now) {
        const s = sparks.get(name) || { last: null, points: Array(SPARK_POINTS).fill(null) };
        if (s.last) {
          const n = count - s.last[1];
          s.points.push(n > 0 && sum >= s.last[0] ? 1000 * (sum - s.last[0]) / n : null);
          s.points.shift();
        }
        s.last = [sum, count];
        sparks.set(name, s);
      }
      drawSparks();
    }
  } catch (err) { /* the server is away; try again */ }
  setTimeout(pollMetrics, 1000);
}

// ---- the 3D preview --------------------------------------------------------------------
// three.js comes from the server itself (/three/, embedded at build time: live/web_assets.h).
// World frame: lightprobe's z-up (x, y, z) is three.js' y-up (x, z, -y), as the glTF
// exporter writes it. The SHADOWED strongest lights are directional lights with shadow
// maps; the others, and the list's "sh9" when it has one, make a THREE.LightProbe, whose
// coefficients are SH9 of radiance in the basis and order core/spherical_harmonics.h uses
// (three's shader multiplies by the clamped-cosine weights pi, 2pi/3, pi/4 itself).
const preview = {
  ready: false, list: null, lights: null, renderedFrame: null, keyDirection: null,
  show(list, lights) { this.list = list; this.lights = lights; if (this.ready) this.apply(); },
  // Azimuth (deg, from +X towards +Y) of the lights' power-weighted mean direction in the
  // frame last rendered.
  keyAzimuthDeg() { const k = this.keyDirection; return k ? Math.atan2(-k[2], k[0]) * 180 / Math.PI : null; },
};
window.lpPreview = preview;  // for tests: the frame last rendered, the sphere's place on screen

const yup = (d) => [d[0], d[2], -d[1]];
// The SH9 basis at a unit vector, the order and constants of core/spherical_harmonics.h.
function shBasis(x, y, z) {
  return [0.282095, 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y, 1.092548 * y * z,
          0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)];
}
// Coefficient rows [r, g, b] x 9 from z-up to y-up: sh9_yup_from_zup of core/spherical_harmonics.cpp.
function shRowsToYup(c) {
  const h = Math.sqrt(3) / 2, out = [];
  for (let i = 0; i < 9; i++) out.push([0, 0, 0]);
  for (let ch = 0; ch < 3; ch++) {
    out[0][ch] = c[0][ch]; out[1][ch] = c[2][ch]; out[2][ch] = -c[1][ch]; out[3][ch] = c[3][ch];
    out[4][ch] = c[7][ch]; out[5][ch] = -c[5][ch]; out[6][ch] = -0.5 * c[6][ch] - h * c[8][ch];
    out[7][ch] = -c[4][ch]; out[8][ch] = -h * c[6][ch] + 0.5 * c[8][ch];
  }
  return out;
}

async function startPreview() {
  const note = (text) => { $("scene-note").textContent = text; };
  let THREE;
  try {
    THREE = await import(url("/three/three.module.js"));
  } catch (err) {
    const built = await fetch(url("/three/three.module.js"), { method: "HEAD" }).then((r) => r.status !== 404, () => true);
    note(built ? "3D preview off: three.js did not load (" + err.message + ")"
               : "3D preview off: this lightprobe was built without three.js (npm package three: scripts/install-js-tools.sh, then rebuild)");
    return;
  }
  const canvas = $("scene-canvas");
  let renderer;
  try {
    renderer = new THREE.WebGLRenderer({ canvas: canvas, antialias: true, preserveDrawingBuffer: true });
  } catch (err) {
    note("3D preview off: this browser has no WebGL");
    return;
  }
  renderer.shadowMap.enabled = true;
  renderer.shadowMap.type = THREE.PCFSoftShadowMap;
  renderer.toneMapping = THREE.NeutralToneMapping;
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x0e1013);
  const camera = new THREE.PerspectiveCamera(35, 16 / 9, 0.1, 50);
  camera.position.set(0, 1.7, 5.6);
  camera.lookAt(0, 0.55, 0);

  const ground = new THREE.Mesh(new THREE.PlaneGeometry(40, 40),
    new THREE.MeshStandardMaterial({ color: 0x9a9a9a, roughness: 0.95, metalness: 0 }));
  ground.rotation.x = -Math.PI / 2;
  ground.receiveShadow = true;
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(0.7, 96, 48), new THREE.MeshLambertMaterial({ color: 0xd0d0d0 }));
  sphere.position.set(-1.0, 0.7, 0);
  const knot = new THREE.Mesh(new THREE.TorusKnotGeometry(0.42, 0.15, 200, 24),
    new THREE.MeshPhysicalMaterial({ color: 0x2c5d9e, roughness: 0.18, metalness: 0, clearcoat: 1, clearcoatRoughness: 0.05 }));
  knot.position.set(1.05, 0.72, 0);
  for (const m of [sphere, knot]) { m.castShadow = true; m.receiveShadow = true; }
  scene.add(ground, sphere, knot);

  const suns = [];
  for (let i = 0; i < SHADOWED; i++) {
    const l = new THREE.DirectionalLight(0xffffff, 0);
    l.castShadow = true;
    l.shadow.mapSize.set(1024, 1024);
    Object.assign(l.shadow.camera, { left: -3.5, right: 3.5, top: 3.5, bottom: -3.5, near: 0.5, far: 30 });
    l.shadow.camera.updateProjectionMatrix();
    l.shadow.bias = -0.0005; l.shadow.normalBias = 0.02;
    scene.add(l, l.target);
    suns.push(l);
  }
  const probe = new THREE.LightProbe();
  scene.add(probe);

  // Exposure: the diffuse irradiance facing the key light is put at a fixed display level,
  // eased over about half a second so that a lamp switching does not pump the picture.
  let exposure = null, target = 1, lastTime = 0;
  // Lists can come faster than a software-rendered WebGL draws (4 shadow maps each): draw
  // in animation frames only, and leave at least 3x the last draw's cost between draws, so
  // that the page stays responsive; the newest list is the one drawn.
  let dirty = false, lastRender = -1e9, renderCost = 0;
  function irradianceLum(sh, n) {  // three's shGetIrradianceAt, luminance of the result
    const [x, y, z] = n, c = sh.coefficients;
    const w = [0.886227, 1.023328 * y, 1.023328 * z, 1.023328 * x, 0.858086 * x * y, 0.858086 * y * z,
               0.743125 * z * z - 0.247708, 0.858086 * x * z, 0.429043 * (x * x - y * y)];
    let e = 0;
    for (let i = 0; i < 9; i++) e += w[i] * (0.2126 * c[i].x + 0.7152 * c[i].y + 0.0722 * c[i].z);
    return e;
  }

  preview.apply = function () {
    const list = this.list, lights = this.lights;
    const strong = lights.slice(0, SHADOWED), rest = lights.slice(SHADOWED);
    // Ambient: the rest as deltas (a light of rgb P at d has coefficients P Y(d)) plus the
    // list's SH9: a "residual" is what the lights leave out and adds; a "map" SH already
    // holds every light, so the shadowed ones come off it and the rest are not added again.
    const sh = new THREE.SphericalHarmonics3();
    const add = (rgb, t, sign) => {
      const y = shBasis(t[0], t[1], t[2]);
      for (let i = 0; i < 9; i++) sh.coefficients[i].add(new THREE.Vector3(rgb[0], rgb[1], rgb[2]).multiplyScalar(sign * y[i]));
    };
    const content = list.sh9 && list.sh9.content;
    if (list.sh9) shRowsToYup(list.sh9.coefficients).forEach((row, i) => sh.coefficients[i].add(new THREE.Vector3(...row)));
    if (content === "map") strong.forEach((l) => add(l.rgb, yup(l.dir), -1));
    else rest.forEach((l) => add(l.rgb, yup(l.dir), 1));
    // Key: the power-weighted mean direction of the lights (methods give lights of nearly
    // equal power, so "the strongest" alone is noise); the irradiance facing it sets the exposure.
    const key = [0, 0, 0];
    for (const l of lights) { const t = yup(l.dir); for (let i = 0; i < 3; i++) key[i] += l.y * t[i]; }
    const norm = Math.hypot(key[0], key[1], key[2]);
    if (norm > 0) for (let i = 0; i < 3; i++) key[i] /= norm; else key[1] = 1;
    let eKey = 0;
    if (list.sh9) eKey = irradianceLum(new THREE.SphericalHarmonics3().fromArray(shRowsToYup(list.sh9.coefficients).flat()), key);
    if (content !== "map")
      for (const l of lights) { const t = yup(l.dir); eKey += l.y * Math.max(0, key[0] * t[0] + key[1] * t[1] + key[2] * t[2]); }
    target = eKey > 0 && isFinite(eKey) ? 1.2 * Math.PI / eKey : 1;
    if (exposure === null) exposure = target;
    this.sh = sh; this.strong = strong; this.keyDirection = key;
    this.pendingFrame = list.frame;
    dirty = true;  // drawn by tick(): at most once per animation frame, see there
  };
  preview.render = function () {
    if (!this.sh) return;
    const started = performance.now();
    for (let i = 0; i < SHADOWED; i++) {
      const l = this.strong[i], sun = suns[i];
      const m = l ? Math.max(l.rgb[0], l.rgb[1], l.rgb[2]) : 0;
      if (!(m > 0)) { sun.intensity = 0; continue; }
      sun.color.setRGB(l.rgb[0] / m, l.rgb[1] / m, l.rgb[2] / m, THREE.LinearSRGBColorSpace);
      sun.intensity = m * exposure;
      const t = yup(l.dir);
      sun.position.set(10 * t[0], 10 * t[1], 10 * t[2]);
    }
    probe.sh.copy(this.sh).scale(exposure);
    renderer.render(scene, camera);
    this.renderedFrame = this.pendingFrame;
    dirty = false;
    lastRender = performance.now(); renderCost = lastRender - started;
  };
  // The sphere's centre and radius on the page, in CSS pixels (tests read the screenshot there).
  preview.sphereOnScreen = function () {
    const r = canvas.getBoundingClientRect();
    const c = sphere.position.clone().project(camera);
    const edge = sphere.position.clone().add(new THREE.Vector3(0.7, 0, 0).applyQuaternion(camera.quaternion)).project(camera);
    const px = (v) => [r.left + (v.x + 1) / 2 * r.width, r.top + (1 - v.y) / 2 * r.height];
    const [cx, cy] = px(c), [ex, ey] = px(edge);
    return { x: cx, y: cy, r: Math.hypot(ex - cx, ey - cy) };
  };

  function resize() {
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (!w || !h) return;
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setSize(w, h, false);
    camera.aspect = w / h; camera.updateProjectionMatrix();
    preview.render();
  }
  new ResizeObserver(resize).observe(canvas);
  function tick(time) {
    const dt = Math.min(1, Math.max(0, (time - lastTime) / 1000)); lastTime = time;
    if (exposure !== null && Math.abs(Math.log(target / exposure)) > 0.005) {
      exposure *= Math.pow(target / exposure, 1 - Math.exp(-dt / 0.5));
      dirty = true;
    }
    if (dirty && time - lastRender >= Math.min(500, 3 * renderCost)) preview.render();
    requestAnimationFrame(tick);
  }
  requestAnimationFrame(tick);
  note("");
  preview.ready = true;
  resize();
  if (preview.list) preview.apply();
}

startPreview();
connect();
pollStatus();
pollMetrics();
</script>
</body>
</html>
)LPHTML";

}  // namespace lp
