// The light server's page (GET /): self-contained (inline CSS and JS, no external
// resources). Shows /probe.png refreshed live with the lights marked on it (from
// /lights/stream), a table of the brightest lights, and the numbers from /status (fps,
// light count, latency, clients, drops). With a token, open the page as /#token=T: the
// fragment never leaves the browser, and the page sends "Authorization: Bearer T" itself
// on every request, so everything goes through fetch(): JSON, the stream (Server-Sent
// Events read from a fetch body, since EventSource cannot send headers) and the picture
// (a blob URL, since <img src> cannot either).
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
  main { padding: 12px 16px; display: grid; gap: 12px; grid-template-columns: minmax(0, 3fr) minmax(260px, 1fr); }
  @media (max-width: 900px) { main { grid-template-columns: 1fr; } }
  .numbers { display: flex; flex-wrap: wrap; gap: 8px; grid-column: 1 / -1; }
  .num { background: #202329; border-radius: 6px; padding: 6px 12px; min-width: 90px; }
  .num b { display: block; font-size: 20px; font-variant-numeric: tabular-nums; }
  .num span { color: #9aa; font-size: 12px; }
  #view { position: relative; background: #000; border-radius: 6px; overflow: hidden; aspect-ratio: 2 / 1; }
  #view img, #view svg { position: absolute; inset: 0; width: 100%; height: 100%; }
  #view img { image-rendering: auto; }
  #view svg circle { fill: none; stroke: #fff; stroke-width: 1.5; vector-effect: non-scaling-stroke; }
  #view svg text { fill: #fff; font-size: 11px; paint-order: stroke; stroke: #000; stroke-width: 3px; }
  #empty { position: absolute; inset: 0; display: flex; align-items: center; justify-content: center; color: #789; }
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
    <div class="num"><b id="clients">-</b><span>stream clients</span></div>
    <div class="num"><b id="dropped">-</b><span>dropped</span></div>
  </div>
  <div id="view">
    <div id="empty">waiting for the first frame...</div>
    <img id="probe" alt="probe preview">
    <svg id="marks" viewBox="0 0 1000 500" preserveAspectRatio="none"></svg>
  </div>
  <div>
    <table><thead><tr><th>id</th><th></th><th>azim&deg;</th><th>elev&deg;</th><th>lum</th><th>%</th></tr></thead>
    <tbody id="rows"></tbody></table>
  </div>
</main>
<footer>Azimuth from +X towards +Y, elevation above the horizon (+Z up). Rings: the latest list; picture: refreshed a few times a second.</footer>
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
const lum = (c) => 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
const fmt = (v, d) => (v === null || v === undefined || !isFinite(v)) ? "-" : Number(v).toFixed(d);
function needToken() { $("dot").className = ""; $("conn").textContent = "needs a token: open /#token=..."; }

function colour(rgb) {
  const m = Math.max(rgb[0], rgb[1], rgb[2], 1e-30);
  const enc = (v) => { v = Math.max(0, Math.min(1, v / m));
    v = v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055; return Math.round(255 * v); };
  return "rgb(" + enc(rgb[0]) + "," + enc(rgb[1]) + "," + enc(rgb[2]) + ")";
}

function showList(list) {
  $("frame").textContent = list.frame;
  $("method").textContent = list.method || "-";
  $("count").textContent = list.lights.length;
  const lights = list.lights.map((l) => {
    const d = l.direction;
    let phi = Math.atan2(d[1], d[0]); if (phi < 0) phi += 2 * Math.PI;
    const theta = Math.acos(Math.max(-1, Math.min(1, d[2])));
    return { id: l.id, rgb: l.rgb, phi: phi, theta: theta, y: lum(l.rgb) };
  });
  const total = lights.reduce((s, l) => s + Math.max(0, l.y), 0) || 1;
  const ymax = lights.reduce((m, l) => Math.max(m, l.y), 0) || 1;
  lights.sort((a, b) => b.y - a.y);
  const svg = $("marks");
  while (svg.firstChild) svg.removeChild(svg.firstChild);
  lights.forEach((l, i) => {
    const x = l.phi / (2 * Math.PI) * 1000, y = l.theta / Math.PI * 500;
    const rel = l.y > 0 ? Math.max(0, 1 + Math.log10(l.y / ymax) / 3) : 0;
    const c = document.createElementNS(SVGNS, "circle");
    c.setAttribute("cx", x); c.setAttribute("cy", y); c.setAttribute("r", 3 + 9 * rel);
    c.style.stroke = colour(l.rgb);
    const t = document.createElementNS(SVGNS, "title");
    t.textContent = "light " + l.id + ": " + (100 * l.y / total).toFixed(1) + " % of the power";
    c.appendChild(t); svg.appendChild(c);
    if (i < 8) {
      const label = document.createElementNS(SVGNS, "text");
      label.setAttribute("x", x + 8); label.setAttribute("y", y - 6); label.textContent = l.id;
      svg.appendChild(label);
    }
  });
  const rows = lights.slice(0, 16).map((l) =>
    "<tr><td>" + l.id + "</td><td><span class='sw' style='background:" + colour(l.rgb) + "'></span></td><td>" +
    fmt(l.phi * 180 / Math.PI, 1) + "</td><td>" + fmt(90 - l.theta * 180 / Math.PI, 1) + "</td><td>" +
    l.y.toPrecision(3) + "</td><td>" + fmt(100 * l.y / total, 1) + "</td></tr>");
  $("rows").innerHTML = rows.join("");
  refreshImage();
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
async function connect() {
  try {
    const r = await fetch(url("/lights/stream"), { headers: headers, cache: "no-store" });
    if (r.status === 401) { needToken(); setTimeout(connect, 5000); return; }
    if (!r.ok || !r.body) throw new Error("stream answered " + r.status);
    $("dot").className = "live"; $("conn").textContent = "live";
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
  $("dot").className = ""; $("conn").textContent = "reconnecting...";
  setTimeout(connect, 1000);
}

async function pollStatus() {
  try {
    const r = await fetch(url("/status"), { headers: headers, cache: "no-cache" });
    if (r.ok) {
      const s = await r.json();
      $("fps").textContent = fmt(s.fps, 1);
      $("latency").textContent = s.latency_seconds === null ? "-" : fmt(1000 * s.latency_seconds, 0);
      $("clients").textContent = s.stream_clients;
      $("dropped").textContent = s.stream_lists_dropped;
      if (s.frame !== null && $("frame").textContent === "-") { $("frame").textContent = s.frame; refreshImage(); }
    } else if (r.status === 401) {
      needToken();
    }
  } catch (err) { /* the server is away; try again */ }
  setTimeout(pollStatus, 1000);
}

connect();
pollStatus();
</script>
</body>
</html>
)LPHTML";

}  // namespace lp
