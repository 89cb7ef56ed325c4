// flexshape live viewer: receives frames over a WebSocket and draws them. No dependencies.
"use strict";

const $ = (id) => document.getElementById(id);
let scene = null;
let last = null;
let shape = null;
let received = 0;
let yaw = -0.6, pitch = 0.45;

let socket = null;

function connect() {
  const ws = new WebSocket(`ws://${location.host}/ws`);
  socket = ws;
  ws.binaryType = "arraybuffer";
  ws.onopen = () => { $("conn").textContent = "live"; $("conn").className = "ok"; };
  ws.onclose = () => {
    $("conn").textContent = "disconnected"; $("conn").className = "bad";
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => {
    if (typeof ev.data !== "string") return showImage(new Uint8Array(ev.data));
    const m = JSON.parse(ev.data);
    if (m.type === "hello") setup(m.scene);
    else if (m.type === "overlays") { shape = m; drawOverlays(); }
    else if (m.type === "frame") {
      last = m;
      received += 1;
      document.body.dataset.frames = String(received);
      figures(m);
      if (m.replay) showReplay(m.replay);
      remember(m);
      draw();
      drawSeries();
      if (m.steering) drawSteering(m.steering);
    }
  };
}

function setup(s) {
  scene = s;
  $("replay").hidden = !s.replay;
  if (s.replay) $("replay-seek").max = String(s.replay - 1);
  const box = $("cameras");
  box.innerHTML = "";
  s.cameras.forEach((name, i) => {
    const card = document.createElement("div");
    card.className = "cam";
    card.innerHTML = `<h2>${name}<span class="check" id="check-${i}"></span></h2><div class="pair">` +
      `<div class="shot"><img id="frame-${i}" alt="${name} frame"><img id="blend-${i}" class="blend" alt="" hidden>` +
      `<canvas id="overlay-${i}" width="256" height="192"></canvas></div>` +
      `<img id="sil-${i}" alt="${name} silhouette"></div>`;
    box.appendChild(card);
  });
  document.querySelectorAll("img.blend").forEach((img) => { img.hidden = !$("show-blend").checked; });
  fitCanvases();
}

// The shape as each camera sees it, over its frame (the message comes right after that frame's
// images): the outline where the fitted tube's sides are, its centerline, bands and tip
// (pixels of the full image, OpenCV convention: (0, 0) is the top-left pixel's centre), and
// how well it explains that camera.
function drawOverlays() {
  const m = shape;
  if (!scene || !m) return;
  const show = $("show-overlay").checked;
  scene.cameras.forEach((_, i) => {
    const c = $(`overlay-${i}`);
    if (!c) return;
    const g = c.getContext("2d");
    g.clearRect(0, 0, c.width, c.height);
    const check = (m.cameras || [])[i];
    $(`check-${i}`).textContent = check ? `residual ${fmt(check.residual_px, 2)} px · IoU ${fmt(check.iou, 3)}` : "";
    const o = (m.overlays || [])[i], size = (scene.image_sizes || [])[i];
    if (!show || !o || !size) return;
    // The image is drawn contained in the canvas's box: the same scale and letterbox here.
    const k = Math.min(c.width / size[0], c.height / size[1]);
    const [ox, oy] = [(c.width - size[0] * k) / 2, (c.height - size[1] * k) / 2];
    const at = (p) => [ox + (p[0] + 0.5) * k, oy + (p[1] + 0.5) * k];
    const line = (pts, colour, width, dash) => {
      g.strokeStyle = colour; g.lineWidth = width; g.setLineDash(dash); g.beginPath();
      let open = false;
      for (const p of pts) {
        if (!p) { open = false; continue; }
        const [x, y] = at(p);
        open ? g.lineTo(x, y) : g.moveTo(x, y); open = true;
      }
      g.stroke(); g.setLineDash([]);
    };
    if (o.truth) line(o.truth, "#ffffff", 1, [1, 3]);
    o.sides.forEach((side) => line(side, "#5fd08a", 1.3, []));
    line(o.centerline, "#4fa3ff", 1, [3, 3]);
    for (const b of o.bands) {
      const [x, y] = at(b);
      g.strokeStyle = "#ffb84f"; g.lineWidth = 1.5; g.beginPath(); g.arc(x, y, 3.5, 0, 2 * Math.PI); g.stroke();
    }
    if (o.tip) {
      const [x, y] = at(o.tip);
      g.fillStyle = "#ff4fd8"; g.beginPath(); g.arc(x, y, 3, 0, 2 * Math.PI); g.fill();
    }
  });
}

function showImage(bytes) {
  const kind = bytes[0], cam = bytes[1];
  const targets = kind === 0 ? [`frame-${cam}`] : [`sil-${cam}`, `blend-${cam}`];
  for (const id of targets) {
    const img = $(id);
    if (!img) continue;
    const url = URL.createObjectURL(new Blob([bytes.subarray(2)], { type: kind === 0 ? "image/jpeg" : "image/png" }));
    const old = img.src;
    img.onload = () => { if (old.startsWith("blob:")) URL.revokeObjectURL(old); };
    img.src = url;
    img.dataset.updates = String(Number(img.dataset.updates || 0) + 1);
  }
}

// A replay's place, and its controls sent back to the server.
function showReplay(r) {
  $("replay-at").textContent = `${r.index + 1} / ${r.frames}`;
  $("replay-play").textContent = r.playing ? "pause" : "play";
  $("replay-play").dataset.playing = String(r.playing);
  if (document.activeElement !== $("replay-seek")) $("replay-seek").value = String(r.index);
}

function control(message) {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(message));
}

function replayControls() {
  $("replay-play").addEventListener("click", () =>
    control({ control: $("replay-play").dataset.playing === "true" ? "pause" : "play" }));
  $("replay-back").addEventListener("click", () => control({ control: "step", by: -1 }));
  $("replay-next").addEventListener("click", () => control({ control: "step", by: 1 }));
  $("replay-seek").addEventListener("input", () => control({ control: "seek", index: Number($("replay-seek").value) }));
}

// Canvases drawn at the size they are shown: views square, the time series and the steering
// plot at their own height, each camera's overlay as large as its frame.
function fitCanvases() {
  let changed = false;
  const size = (c, w, h) => {
    if (!(w > 0 && h > 0)) return; // hidden: sized when shown
    w = Math.round(w); h = Math.round(h);
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; changed = true; }
  };
  for (const id of ["top", "front", "side", "view3d"]) size($(id), $(id).clientWidth, $(id).clientWidth);
  for (const id of ["series", "steerplot"]) size($(id), $(id).clientWidth, $(id).height);
  document.querySelectorAll(".cam .shot").forEach((shot) => {
    const c = shot.querySelector("canvas");
    if (c) size(c, shot.clientWidth, shot.clientHeight);
  });
  if (changed) { draw(); drawSeries(); drawOverlays(); if (last && last.steering) drawSteering(last.steering); }
}

function toggles() {
  $("show-overlay").addEventListener("change", drawOverlays);
  $("show-blend").addEventListener("change", () => {
    document.querySelectorAll("img.blend").forEach((img) => { img.hidden = !$("show-blend").checked; });
  });
}

const fmt = (v, d) => (v === null || v === undefined || !isFinite(v)) ? "–" : v.toFixed(d);

function figures(m) {
  const r = m.record, s = m.stats;
  $("frame").textContent = r.frame;
  $("status").textContent = r.status;
  $("fps").textContent = fmt(s.fps, 1);
  $("latency").textContent = `${fmt(s.latency_ms, 1)} ms`;
  $("dropped").textContent = s.dropped;
  $("arc").textContent = `${fmt(r.arc_length, 1)} mm`;
  const k = r.arc_fit ? r.arc_fit.curvature : null;
  let curvature = k ? `${fmt(k * 1000, 2)} 1/m (r ${fmt(1 / k, 0)} mm)` : "–";
  if (r.arc_fit && r.arc_fit.kappa_x !== undefined) {
    curvature += `; κx ${fmt(r.arc_fit.kappa_x * 1000, 2)}, κz ${fmt(r.arc_fit.kappa_z * 1000, 2)} 1/m`;
  }
  $("curvature").textContent = curvature;
  $("tip").textContent = r.tip ? r.tip.map((v) => fmt(v, 1)).join(", ") + " mm" : "–";
  if (s.truth_rms_mm !== undefined) {
    $("truth-fig").hidden = false;
    $("truth").textContent = `rms ${fmt(s.truth_rms_mm, 3)} mm, tip ${fmt(s.truth_tip_mm, 2)} mm`;
  }
  const st = m.steering;
  $("steer-fig").hidden = !st;
  $("steer-panel").hidden = !st;
  if (st) {
    const now = st.history[st.history.length - 1] || {};
    const k = (v) => v.map((x) => fmt(x, 1)).join(", ");
    $("steer").textContent = `target ${st.target_index + 1}/${st.targets}; tip ${fmt(now.sensed_error_mm, 2)} mm from it` +
      (now.true_error_mm != null ? ` (true ${fmt(now.true_error_mm, 2)})` : "") +
      `; Kx, Kz ${k(st.stiffness)}` + (st.true_stiffness ? ` (true ${k(st.true_stiffness)})` : "");
  }
}

// The closed loop's history: tip error (log scale) above, curvatures below.
function drawSteering(st) {
  const c = $("steerplot"), g = c.getContext("2d");
  g.clearRect(0, 0, c.width, c.height);
  const h = st.history;
  if (h.length === 0) return;
  const [left, right] = [46, c.width - 10];
  const f0 = h[0].frame, f1 = Math.max(h[h.length - 1].frame, f0 + 1);
  const x = (f) => left + (f - f0) / (f1 - f0) * (right - left);
  const panels = [[8, 118], [140, 250]];
  g.font = "11px system-ui"; g.lineWidth = 1;
  for (const [top, bottom] of panels) {
    g.strokeStyle = "#3a4050"; g.strokeRect(left, top, right - left, bottom - top);
  }
  for (let i = 1; i < h.length; i++) {
    if (h[i].target_index !== h[i - 1].target_index) {
      g.strokeStyle = "#555b6a";
      for (const [top, bottom] of panels) { g.beginPath(); g.moveTo(x(h[i].frame), top); g.lineTo(x(h[i].frame), bottom); g.stroke(); }
    }
  }
  // Tip error, mm, log scale between 0.01 and the largest.
  const errors = h.flatMap((s) => [s.sensed_error_mm, s.true_error_mm]).filter((v) => v != null && v > 0);
  const hi = Math.log10(Math.max(1, ...errors)), lo = -2;
  const ye = (v) => 118 - (Math.log10(Math.max(v, 0.01)) - lo) / (hi - lo) * 110;
  g.fillStyle = "#8a90a0";
  for (let d = lo; d <= hi; d++) g.fillText(`${Math.pow(10, d)} mm`, 2, ye(Math.pow(10, d)) + 4);
  const line = (key, colour, y, dots) => {
    g.strokeStyle = colour; g.fillStyle = colour; g.lineWidth = 1.5; g.beginPath();
    let open = false;
    for (const s of h) {
      const v = key(s);
      if (v == null) { open = false; continue; }
      const [px, py] = [x(s.frame), y(v)];
      if (dots) { g.fillRect(px - 2, py - 2, 4, 4); continue; }
      open ? g.lineTo(px, py) : g.moveTo(px, py); open = true;
    }
    if (!dots) g.stroke();
  };
  line((s) => s.true_error_mm, "#5fd08a", ye, false);
  line((s) => s.sensed_error_mm, "#4fa3ff", ye, false);
  // Curvatures, 1/m.
  const ks = h.flatMap((s) => [...s.commanded_kappa, ...(s.sensed_kappa || [])]).map((v) => v * 1000);
  const kmax = Math.max(1, ...ks.map(Math.abs));
  const yk = (v) => 195 - v * 1000 / kmax * 52;
  g.fillStyle = "#8a90a0";
  g.fillText(`${fmt(kmax, 1)}/m`, 2, yk(kmax / 1000) + 4); g.fillText("0", 2, yk(0) + 4);
  g.fillText(`-${fmt(kmax, 1)}/m`, 2, yk(-kmax / 1000) + 4);
  [[0, "#ffb84f"], [1, "#c08bff"]].forEach(([i, colour]) => {
    line((s) => s.commanded_kappa[i], colour, yk, false);
    line((s) => s.sensed_kappa ? s.sensed_kappa[i] : null, colour, yk, true);
  });
}

// The record's figures over the last SERIES_S seconds (by arrival), for the time-series plots.
const SERIES_S = 30;
const history = [];
// Per camera (frusta, residual lines): apart from the shape's own colours.
const CAMERA_COLOURS = ["#e6d85a", "#5ad8e6", "#d88cff", "#ff8c5a", "#9ae65a", "#ff5a9a", "#5a8cff", "#c8ccd6"];

function remember(m) {
  const r = m.record, now = performance.now() / 1000;
  history.push({
    t: now,
    tip: r.tip,
    curvature: r.arc_fit ? r.arc_fit.curvature * 1000 : null,
    fps: m.stats.fps,
    latency: m.stats.latency_ms,
    residuals: (r.cameras || []).map((c) => c.residual_px),
    stages: r.timings_ms,
  });
  while (history.length && history[0].t < now - SERIES_S) history.shift();
}

// Panels stacked over the last SERIES_S seconds, and the newest frame's stage times as a bar.
function drawSeries() {
  const c = $("series"), g = c.getContext("2d");
  g.clearRect(0, 0, c.width, c.height);
  if (!history.length) return;
  const now = history[history.length - 1].t;
  const [left, right] = [52, c.width - 10];
  const x = (t) => right - (now - t) / SERIES_S * (right - left);
  g.font = "11px system-ui";
  const panel = (top, bottom, title, lines) => {
    g.strokeStyle = "#3a4050"; g.lineWidth = 1; g.strokeRect(left, top, right - left, bottom - top);
    const values = lines.flatMap((l) => history.map(l.value)).filter((v) => v != null && isFinite(v));
    if (!values.length) return;
    let [lo, hi] = [Math.min(...values), Math.max(...values)];
    if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
    const y = (v) => bottom - 3 - (v - lo) / (hi - lo) * (bottom - top - 6);
    g.fillStyle = "#8a90a0";
    g.fillText(title, left + 4, top + 11);
    g.fillText(fmt(hi, 2), 2, top + 9); g.fillText(fmt(lo, 2), 2, bottom - 1);
    for (const l of lines) {
      g.strokeStyle = l.colour; g.lineWidth = 1.5; g.beginPath();
      let open = false;
      for (const h of history) {
        const v = l.value(h);
        if (v == null || !isFinite(v)) { open = false; continue; }
        open ? g.lineTo(x(h.t), y(v)) : g.moveTo(x(h.t), y(v)); open = true;
      }
      g.stroke();
    }
  };
  // The tip about its mean over the window, so that a millimetre shows.
  const mean = [0, 1, 2].map((i) => {
    const v = history.filter((h) => h.tip).map((h) => h.tip[i]);
    return v.length ? v.reduce((a, b) => a + b, 0) / v.length : 0;
  });
  panel(4, 74, "tip − mean (mm)", ["#ff6b6b", "#5fd08a", "#4fa3ff"].map((colour, i) => ({ colour, value: (h) => h.tip ? h.tip[i] - mean[i] : null })));
  panel(80, 130, "curvature (1/m)", [{ colour: "#ffb84f", value: (h) => h.curvature }]);
  panel(136, 186, "frames/s", [{ colour: "#c8ccd6", value: (h) => h.fps }]);
  panel(192, 242, "latency (ms)", [{ colour: "#ffb84f", value: (h) => h.latency }]);
  const cams = Math.max(0, ...history.map((h) => h.residuals.length));
  panel(248, 308, "outline residual per camera (px)", [...Array(cams).keys()].map((i) => ({ colour: CAMERA_COLOURS[i % 8], value: (h) => h.residuals[i] })));
  // This frame's time per stage.
  const stages = history[history.length - 1].stages || {};
  const names = ["silhouettes", "carve", "bands", "shape", "fit"];
  const total = names.reduce((a, n) => a + (stages[n] || 0), 0);
  let at = left;
  const top = 330, width = right - left;
  g.fillStyle = "#8a90a0"; g.fillText(`this frame's stages: ${fmt(total, 2)} ms`, left, top - 5);
  names.forEach((n, i) => {
    const w = total > 0 ? (stages[n] || 0) / total * width : 0;
    g.fillStyle = CAMERA_COLOURS[(i + 3) % 8]; g.fillRect(at, top, w, 16);
    if (w > 60) { g.fillStyle = "#14161b"; g.fillText(`${n} ${fmt(stages[n], 2)}`, at + 4, top + 12); }
    at += w;
  });
  c.dataset.points = String(history.length);
}

// Orthographic views: [canvas id, horizontal axis, vertical axis].
const VIEWS = [["top", 0, 1], ["front", 0, 2], ["side", 1, 2]];
// Per view: zoom factor and pan (canvas pixels) the user set; reset by a double click.
const zoomPan = Object.fromEntries(["top", "front", "side", "view3d"].map((id) => [id, { zoom: 1, pan: [0, 0] }]));

// What the views frame: the tube with a margin (auto-fit, the default), or the whole volume.
// Rounded to 10 mm so that the views do not twitch from frame to frame.
function framed() {
  const v = scene.volume;
  const pts = last.record.centerline;
  if (!$("fit-tube").checked || pts.length < 2) return v;
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (const p of pts) for (let i = 0; i < 3; i++) { lo[i] = Math.min(lo[i], p[i]); hi[i] = Math.max(hi[i], p[i]); }
  const margin = 15;
  return [0, 1, 2].map((i) => Math.floor((lo[i] - margin) / 10) * 10)
    .concat([0, 1, 2].map((i) => Math.ceil((hi[i] + margin) / 10) * 10));
}

// A round step (1, 2 or 5 × 10^k mm) about a sixth of `span`.
function gridStep(span) {
  const raw = span / 6, k = Math.pow(10, Math.floor(Math.log10(raw)));
  return [1, 2, 5, 10].map((m) => m * k).find((s) => s >= raw) || 10 * k;
}

function draw() {
  if (!scene || !last) return;
  const box = framed();
  for (const [id, a, b] of VIEWS) {
    const c = $(id), g = c.getContext("2d"), zp = zoomPan[id];
    const span = Math.max(box[a + 3] - box[a], box[b + 3] - box[b], 40);
    const scale = (c.width - 20) / span * zp.zoom;
    const [ca, cb] = [(box[a] + box[a + 3]) / 2, (box[b] + box[b + 3]) / 2];
    const px = (p) => [c.width / 2 + (p[a] - ca) * scale + zp.pan[0], c.height / 2 - (p[b] - cb) * scale + zp.pan[1]];
    g.clearRect(0, 0, c.width, c.height);
    grid(g, c, px, scale, a, b);
    paint(g, c, px, scale);
  }
  const c = $("view3d"), g = c.getContext("2d"), zp = zoomPan.view3d;
  // With the cameras shown, the 3-D view frames them too.
  const frusta = $("show-cameras").checked ? (scene.frusta || []) : [];
  const box3 = box.slice();
  for (const f of frusta) for (let i = 0; i < 3; i++) {
    box3[i] = Math.min(box3[i], f.centre[i]); box3[i + 3] = Math.max(box3[i + 3], f.centre[i]);
  }
  const centre = [0, 1, 2].map((i) => (box3[i] + box3[i + 3]) / 2);
  const diag = Math.hypot(box3[3] - box3[0], box3[4] - box3[1], box3[5] - box3[2]);
  const scale = (c.width - 20) / Math.max(diag, 40) * zp.zoom;
  const [cy, sy, cp, sp] = [Math.cos(yaw), Math.sin(yaw), Math.cos(pitch), Math.sin(pitch)];
  // Screen x, screen y and depth (larger is farther) of a world point.
  const project = (p) => {
    const x = p[0] - centre[0], y = p[1] - centre[1], z = p[2] - centre[2];
    const x1 = cy * x - sy * y, y1 = sy * x + cy * y;
    const up = cp * z - sp * y1, depth = sp * z + cp * y1;
    return [c.width / 2 + x1 * scale + zp.pan[0], c.height / 2 - up * scale + zp.pan[1], depth];
  };
  g.clearRect(0, 0, c.width, c.height);
  paint(g, c, project, scale, scene.volume);
  frusta.forEach((f, i) => drawFrustum(g, project, f, scene.cameras[i], CAMERA_COLOURS[i % 8], centre));
  c.dataset.frusta = String(frusta.length);
}

// A camera as a pyramid from its centre toward what it sees, a quarter of the way to the
// middle of the view, with its name.
function drawFrustum(g, project, f, name, colour, target) {
  const reach = 0.25 * Math.hypot(...[0, 1, 2].map((i) => target[i] - f.centre[i]));
  const [ax, ay, az] = f.axes;
  const corner = ([x, y]) => [0, 1, 2].map((i) => f.centre[i] + reach * (az[i] + x * ax[i] + y * ay[i]));
  const apex = project(f.centre), base = f.corners.map((q) => project(corner(q)));
  g.strokeStyle = colour; g.lineWidth = 1.2; g.beginPath();
  base.forEach((p, k) => {
    g.moveTo(apex[0], apex[1]); g.lineTo(p[0], p[1]);
    const q = base[(k + 1) % 4]; g.moveTo(p[0], p[1]); g.lineTo(q[0], q[1]);
  });
  g.stroke();
  // The image's top edge drawn thicker: which way is up in that camera.
  g.lineWidth = 3; g.beginPath(); g.moveTo(base[0][0], base[0][1]); g.lineTo(base[1][0], base[1][1]); g.stroke();
  g.fillStyle = colour; g.font = "11px system-ui"; g.fillText(name, apex[0] + 4, apex[1] - 4);
}

// Grid lines every round step and a scale bar, in an orthographic view.
function grid(g, c, px, scale, a, b) {
  const step = gridStep(c.width / scale);
  const origin = px([0, 0, 0]);
  g.strokeStyle = "#262a33"; g.lineWidth = 1;
  const first = (o, s) => o - Math.ceil(o / (step * s)) * step * s;
  for (let x = first(origin[0], scale); x < c.width; x += step * scale) {
    g.beginPath(); g.moveTo(x, 0); g.lineTo(x, c.height); g.stroke();
  }
  for (let y = first(origin[1], scale); y < c.height; y += step * scale) {
    g.beginPath(); g.moveTo(0, y); g.lineTo(c.width, y); g.stroke();
  }
  const len = step * scale, y = c.height - 8;
  g.strokeStyle = "#c8ccd6"; g.fillStyle = "#c8ccd6"; g.lineWidth = 2;
  g.beginPath(); g.moveTo(8, y); g.lineTo(8 + len, y); g.stroke();
  g.font = "11px system-ui"; g.fillText(`${step} mm`, 12 + len, y + 4);
  c.dataset.gridMm = String(step);
  c.dataset.scale = scale.toFixed(4);
}

function paint(g, c, px, scale, box) {
  if (box) {
    g.strokeStyle = "#3a4050"; g.lineWidth = 1;
    const corners = [];
    for (let i = 0; i < 8; i++) corners.push([box[i & 1 ? 3 : 0], box[i & 2 ? 4 : 1], box[i & 4 ? 5 : 2]]);
    for (let i = 0; i < 8; i++) for (const bit of [1, 2, 4]) if (!(i & bit)) {
      const [p, q] = [px(corners[i]), px(corners[i | bit])];
      g.beginPath(); g.moveTo(p[0], p[1]); g.lineTo(q[0], q[1]); g.stroke();
    }
    const o = [box[0], box[1], box[2]];
    [["x", "#ff6b6b"], ["y", "#5fd08a"], ["z", "#4fa3ff"]].forEach(([name, colour], i) => {
      const e = o.slice(); e[i] += 40;
      const [p, q] = [px(o), px(e)];
      g.strokeStyle = colour; g.lineWidth = 2; g.beginPath(); g.moveTo(p[0], p[1]); g.lineTo(q[0], q[1]); g.stroke();
      g.fillStyle = colour; g.fillText(name, q[0] + 3, q[1] - 3);
    });
  }
  const cloud = last.cloud, bands = last.cloud_band;
  const dot = Math.max(1.5, scene.voxel * scale);
  const points = [];
  for (let i = 0; i < bands.length; i++) points.push(px([cloud[3 * i], cloud[3 * i + 1], cloud[3 * i + 2]]).concat([bands[i]]));
  // Far points first, so that near ones cover them (the 3-D view gives a depth).
  if (points.length && points[0].length === 4) points.sort((p, q) => q[2] - p[2]);
  for (const p of points) {
    const [x, y, band] = [p[0], p[1], p[p.length - 1]];
    g.fillStyle = band ? "rgba(255,90,90,0.8)" : "rgba(154,163,181,0.35)";
    g.fillRect(x - dot / 2, y - dot / 2, dot, dot);
  }
  const r = last.record;
  const truth = last.truth_centerline;
  if (truth && truth.length > 1) {
    // The truth under the measured centerline, wider and white: where they part, it shows.
    g.strokeStyle = "rgba(255,255,255,0.85)"; g.lineWidth = 5; g.beginPath();
    truth.forEach((p, i) => { const [x, y] = px(p); i ? g.lineTo(x, y) : g.moveTo(x, y); });
    g.stroke();
  }
  if (r.centerline.length > 1) {
    g.strokeStyle = "#4fa3ff"; g.lineWidth = 2.5; g.beginPath();
    r.centerline.forEach((p, i) => { const [x, y] = px(p); i ? g.lineTo(x, y) : g.moveTo(x, y); });
    g.stroke();
  }
  for (const b of r.bands) {
    const [x, y] = px(b.position);
    g.strokeStyle = "#ffb84f"; g.lineWidth = 2; g.beginPath(); g.arc(x, y, 5, 0, 2 * Math.PI); g.stroke();
  }
  if (r.tip) {
    const [x, y] = px(r.tip);
    g.fillStyle = "#5fd08a"; g.beginPath(); g.arc(x, y, 4.5, 0, 2 * Math.PI); g.fill();
  }
  if (last.steering) {
    // The target: a ringed cross, and a dashed line to it from the sensed tip.
    const [x, y] = px(last.steering.target);
    g.strokeStyle = "#ff4fd8"; g.lineWidth = 2;
    g.beginPath(); g.arc(x, y, 7, 0, 2 * Math.PI);
    g.moveTo(x - 10, y); g.lineTo(x + 10, y); g.moveTo(x, y - 10); g.lineTo(x, y + 10); g.stroke();
    if (r.tip) {
      const [tx, ty] = px(r.tip);
      g.setLineDash([4, 3]); g.lineWidth = 1;
      g.beginPath(); g.moveTo(tx, ty); g.lineTo(x, y); g.stroke(); g.setLineDash([]);
    }
  }
}

// Drag turns the 3-D view (shift-drag pans it) and pans the others; the wheel zooms about the
// pointer; a double click returns to the fitted view.
(function navigate() {
  for (const id of ["top", "front", "side", "view3d"]) {
    const c = $(id), zp = zoomPan[id];
    let drag = null;
    c.addEventListener("pointerdown", (e) => {
      drag = { x: e.clientX, y: e.clientY, yaw, pitch, pan: zp.pan.slice(), turn: id === "view3d" && !e.shiftKey };
      c.setPointerCapture && c.setPointerCapture(e.pointerId);
    });
    c.addEventListener("pointerup", () => { drag = null; });
    c.addEventListener("pointermove", (e) => {
      if (!drag) return;
      const [dx, dy] = [e.clientX - drag.x, e.clientY - drag.y];
      if (drag.turn) {
        yaw = drag.yaw + dx * 0.01;
        pitch = Math.max(-1.5, Math.min(1.5, drag.pitch + dy * 0.01));
      } else {
        zp.pan = [drag.pan[0] + dx, drag.pan[1] + dy];
      }
      draw();
    });
    c.addEventListener("wheel", (e) => {
      e.preventDefault();
      const k = Math.exp(-e.deltaY * 0.0015);
      const r = c.getBoundingClientRect();
      // Keep the point under the pointer where it is.
      const [mx, my] = [(e.clientX - r.left) * c.width / r.width - c.width / 2, (e.clientY - r.top) * c.height / r.height - c.height / 2];
      zp.pan = [mx - (mx - zp.pan[0]) * k, my - (my - zp.pan[1]) * k];
      zp.zoom *= k;
      draw();
    }, { passive: false });
    c.addEventListener("dblclick", () => { zp.zoom = 1; zp.pan = [0, 0]; draw(); });
  }
  $("fit-tube").addEventListener("change", draw);
  $("show-cameras").addEventListener("change", draw);
})();

toggles();
replayControls();
new ResizeObserver(fitCanvases).observe(document.body);
window.addEventListener("resize", fitCanvases);
fitCanvases();
connect();
