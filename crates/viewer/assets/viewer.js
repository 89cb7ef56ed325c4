// flexshape live viewer: receives frames over a WebSocket and draws them. No dependencies.
"use strict";

const $ = (id) => document.getElementById(id);
let scene = null;
let last = null;
let received = 0;
let yaw = -0.6, pitch = 0.45;

function connect() {
  const ws = new WebSocket(`ws://${location.host}/ws`);
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
    else if (m.type === "frame") {
      last = m;
      received += 1;
      document.body.dataset.frames = String(received);
      figures(m);
      draw();
    }
  };
}

function setup(s) {
  scene = s;
  const box = $("cameras");
  box.innerHTML = "";
  s.cameras.forEach((name, i) => {
    const card = document.createElement("div");
    card.className = "cam";
    card.innerHTML = `<h2>${name}</h2><div class="pair"><img id="frame-${i}" alt="${name} frame">` +
      `<img id="sil-${i}" alt="${name} silhouette"></div>`;
    box.appendChild(card);
  });
}

function showImage(bytes) {
  const kind = bytes[0], cam = bytes[1];
  const img = $(`${kind === 0 ? "frame" : "sil"}-${cam}`);
  if (!img) return;
  const url = URL.createObjectURL(new Blob([bytes.subarray(2)], { type: kind === 0 ? "image/jpeg" : "image/png" }));
  const old = img.src;
  img.onload = () => { if (old.startsWith("blob:")) URL.revokeObjectURL(old); };
  img.src = url;
  img.dataset.updates = String(Number(img.dataset.updates || 0) + 1);
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
}

// Orthographic views: [canvas id, horizontal axis, vertical axis].
const VIEWS = [["top", 0, 1], ["front", 0, 2], ["side", 1, 2]];

function draw() {
  if (!scene || !last) return;
  const v = scene.volume;
  const span = Math.max(v[3] - v[0], v[4] - v[1], v[5] - v[2]);
  for (const [id, a, b] of VIEWS) {
    const c = $(id), g = c.getContext("2d");
    const scale = (c.width - 20) / span;
    const px = (p) => [10 + (p[a] - v[a]) * scale, c.height - 10 - (p[b] - v[b]) * scale];
    paint(g, c, px, scale);
  }
  const c = $("view3d"), g = c.getContext("2d");
  const centre = [0, 1, 2].map((i) => (v[i] + v[i + 3]) / 2);
  const scale = (c.width - 20) / (span * 1.75);
  const [cy, sy, cp, sp] = [Math.cos(yaw), Math.sin(yaw), Math.cos(pitch), Math.sin(pitch)];
  const px = (p) => {
    const x = p[0] - centre[0], y = p[1] - centre[1], z = p[2] - centre[2];
    const x1 = cy * x - sy * y, y1 = sy * x + cy * y;
    const up = cp * z - sp * y1;
    return [c.width / 2 + x1 * scale, c.height / 2 - up * scale];
  };
  paint(g, c, px, scale, v);
}

function paint(g, c, px, scale, box) {
  g.clearRect(0, 0, c.width, c.height);
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
  for (let i = 0; i < bands.length; i++) {
    const [x, y] = px([cloud[3 * i], cloud[3 * i + 1], cloud[3 * i + 2]]);
    g.fillStyle = bands[i] ? "rgba(255,90,90,0.8)" : "rgba(154,163,181,0.35)";
    g.fillRect(x - dot / 2, y - dot / 2, dot, dot);
  }
  const r = last.record;
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
}

(function rotate() {
  const c = $("view3d");
  let drag = null;
  c.addEventListener("pointerdown", (e) => { drag = [e.clientX, e.clientY, yaw, pitch]; c.setPointerCapture(e.pointerId); });
  c.addEventListener("pointerup", () => { drag = null; });
  c.addEventListener("pointermove", (e) => {
    if (!drag) return;
    yaw = drag[2] + (e.clientX - drag[0]) * 0.01;
    pitch = Math.max(-1.5, Math.min(1.5, drag[3] + (e.clientY - drag[1]) * 0.01));
    draw();
  });
})();

connect();
