// pvrsim view: the page. One WebSocket to the server: it sends `hello`,
// then per frame a JSON description followed by the frame as a binary
// message; the page sends camera / transfer-function / option requests.
// Test hooks (stable): #frame has data-seq (the frame number shown) and
// data-scale (1: a full-resolution frame); window.pvrsimStats holds the
// measured input-to-frame latencies.

import { orbit, zoom, pan, axisView } from "./camera.js";
import { TfEditor } from "./tf.js";

const $ = (id) => document.getElementById(id);
const search = location.search;
const token = new URLSearchParams(search).get("token") || "";
const img = $("frame");
const stats = (window.pvrsimStats = { latencies: [], frames: [], errors: [] });

let ws = null;
let cam = null;          // the camera the page shows / asks for
let home = null;         // the scene's camera (key r)
let fullSize = null;     // the full image size
let nextMeta = null;     // the description of the binary message to come
let inputNo = 0;
const sentAt = new Map(); // input number -> performance.now() when sent
let shownUrl = null;
let recording = null;    // the series being recorded: [[frame]] tables
let data = null;         // the data's fields and time steps (hello), the ones shown
let movie = "off";       // the movie recorder: off, recording, writing

const tf = new TfEditor($("tf"), {
  preset: $("preset"), log: $("log-hist"), scale: $("opacity-scale"),
  scaleValue: $("opacity-scale-value"), colour: $("point-colour"),
}, (transfer, interacting) => send({ type: "view", transfer, interacting }));

function send(msg) {
  if (!ws || ws.readyState !== WebSocket.OPEN) return;
  inputNo += 1;
  msg.input = inputNo;
  sentAt.set(inputNo, performance.now());
  if (sentAt.size > 2000) sentAt.delete(sentAt.keys().next().value);
  ws.send(JSON.stringify(msg));
  if (recording && (msg.type === "view" || msg.type === "data")) record(msg);
}

function record(msg) {
  const f = {};
  if (msg.camera) { f.eye = msg.camera.eye; f.target = msg.camera.target; f.up = msg.camera.up; }
  if (msg.transfer) f.transfer = msg.transfer;
  if (msg.field) f.field = msg.field;
  if (msg.step !== undefined && data) f.mesh = data.step_paths[msg.step];
  recording.push(f);
}

function seriesToml(frames) {
  const num = (v) => (Number.isInteger(v) ? v.toFixed(1) : String(v));
  const arr = (a) => "[" + a.map(num).join(", ") + "]";
  let s = "# recorded by pvrsim view: replay with pvrsim cluster SCENE --series THIS.toml\n";
  s += "[[frame]]\n";
  for (const f of frames) {
    s += "\n[[frame]]\n";
    if (f.eye) s += `eye = ${arr(f.eye)}\ntarget = ${arr(f.target)}\nup = ${arr(f.up)}\n`;
    if (f.transfer) s += `transfer = { unit_distance = ${num(f.transfer.unit_distance)}, points = [${f.transfer.points.map(arr).join(", ")}] }\n`;
    if (f.field) s += `field = ${JSON.stringify(f.field)}\n`;
    if (f.mesh) s += `mesh = ${JSON.stringify(f.mesh)}\n`;
  }
  return s;
}

function setCamera(c, interacting) {
  cam = c;
  send({ type: "view", camera: cam, interacting });
}

function showError(text) {
  stats.errors.push(text);
  if (movie === "writing" && text.startsWith("movie")) {
    movie = "off";
    $("movie").textContent = "Record movie";
    $("movie").disabled = false;
  }
  const e = $("error");
  e.textContent = text;
  e.hidden = false;
  clearTimeout(showError.t);
  showError.t = setTimeout(() => (e.hidden = true), 8000);
}

function median(a) {
  if (!a.length) return 0;
  const s = a.slice().sort((x, y) => x - y);
  return s[Math.floor(s.length / 2)];
}

function layout(w, h) {
  const k = Math.min(640 / w, 560 / h);
  img.style.width = `${Math.round(w * k)}px`;
  img.style.height = `${Math.round(h * k)}px`;
}

function onFrame(meta, blob) {
  const url = URL.createObjectURL(blob);
  const t0 = sentAt.get(meta.input);
  const probe = new Image();
  probe.onload = () => {
    img.src = url;
    img.dataset.seq = String(meta.seq);
    img.dataset.scale = String(meta.scale);
    if (shownUrl) URL.revokeObjectURL(shownUrl);
    shownUrl = url;
    const now = performance.now();
    let latency = null;
    if (t0 !== undefined) {
      latency = now - t0;
      sentAt.delete(meta.input);
      stats.latencies.push({ ms: latency, scale: meta.scale, seq: meta.seq });
    }
    stats.frames.push({ seq: meta.seq, scale: meta.scale, coarse: meta.coarse, at: now, render_ms: meta.render_ms, encode_ms: meta.encode_ms, bytes: meta.bytes });
    if (stats.frames.length > 5000) stats.frames.shift();
    const recent = stats.latencies.slice(-30).map((l) => l.ms);
    $("stats").textContent =
      `frame ${meta.seq}  ${meta.width}x${meta.height} (1/${meta.scale}${meta.coarse ? ", coarse mesh" : ""}, ${meta.cells} cells)  ${meta.format.replace("image/", "")} ${(meta.bytes / 1024).toFixed(1)} KiB\n` +
      `render ${meta.render_ms.toFixed(1)} ms  encode ${meta.encode_ms.toFixed(1)} ms  ` +
      `latency ${latency === null ? "-" : latency.toFixed(0)} ms (median ${median(recent).toFixed(0)})  ${meta.fps.toFixed(1)} fps`;
    if (meta.nodes && meta.nodes.length) nodeBars(meta.nodes);
  };
  probe.src = url;
  if (meta.scene) {
    if (!cam) { cam = meta.scene.camera; home = cam; }
    if (!fullSize || fullSize.width !== meta.scene.image.width || fullSize.height !== meta.scene.image.height) {
      fullSize = meta.scene.image;
      layout(fullSize.width, fullSize.height);
    }
    if (!tf.points.length) tf.set(meta.scene.transfer, null);
  }
}

const BARS = [
  ["scan", (n) => n.scan_s ?? n.render_s ?? 0, (v) => `${(v * 1e3).toFixed(0)} ms`],
  // Per-node compositing time is modelled only (null on the wall clock,
  // where the report has no per-node phase-2 figure): say so, never "0 ms".
  ["composite", (n) => n.composite_s ?? null, (v) => (v == null ? "n/a (wall clock)" : `${(v * 1e3).toFixed(0)} ms`)],
  ["cells", (n) => n.cells_processed ?? n.voxels ?? 0, (v) => `${v}`],
  ["skipped", (n) => n.cells_skipped_ert ?? 0, (v) => `${v}`],
  ["bytes", (n) => n.bytes_sent ?? 0, (v) => `${(v / 1024).toFixed(0)} KiB`],
];

function nodeBars(nodes) {
  $("cluster").hidden = false;
  const box = $("node-bars");
  const max = BARS.map(([, f]) => Math.max(1e-12, ...nodes.map(f)));
  let html = `<div class="node head"><span>node</span>${BARS.map(([n]) => `<span>${n}</span>`).join("")}</div>`;
  nodes.forEach((n, i) => {
    html += `<div class="node"><span>${n.rank ?? i}</span>` + BARS.map(([, f, fmt], k) => {
      const v = f(n);
      return `<div class="bar"><div style="width:${(100 * (v ?? 0)) / max[k]}%"></div><span>${fmt(v)}</span></div>`;
    }).join("") + "</div>";
  });
  box.innerHTML = html;
}

// The data shown: its field (the histogram and range under the transfer
// function follow it) and time step; sent by hello and by each change.
function showData(h) {
  data = h;
  $("field").textContent = `[${h.range[0].toPrecision(4)}, ${h.range[1].toPrecision(4)}]`;
  tf.hist = h.histogram;
  tf.draw();
  const f = $("field-select");
  f.innerHTML = "";
  for (const n of h.fields) f.add(new Option(n, n, false, n === h.field));
  f.disabled = h.fields.length < 2;
  const multi = h.steps.length > 1;
  $("steps").hidden = !multi;
  const st = $("step");
  st.max = String(h.steps.length - 1);
  st.value = String(h.step);
  $("step-name").textContent = `${h.step}: ${h.steps[h.step]}`;
}

function hello(h) {
  $("scene-name").textContent = h.scene_name;
  showData(h);
  $("field-select").onchange = () => send({ type: "data", field: $("field-select").value });
  $("step").oninput = () => {
    const k = +$("step").value;
    $("step-name").textContent = `${k}: ${data.steps[k]}`;
    send({ type: "data", step: k });
  };
  const r = $("renderer");
  r.innerHTML = "";
  if (h.renderer === "default") r.add(new Option("default", "default", true, true));
  for (const n of h.renderers) r.add(new Option(n, n, false, n === h.renderer));
  r.onchange = () => r.value !== "default" && send({ type: "options", renderer: r.value });
  $("ert").value = h.ert;
  $("ert").onchange = () => send({ type: "options", ert: +$("ert").value });
  if (h.nodes) $("transport").textContent = `${h.nodes} nodes, ${h.transport}`;
}

function connect() {
  ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws${search}`);
  ws.binaryType = "blob";
  ws.onopen = () => ($("status").textContent = "connected");
  ws.onclose = () => {
    $("status").textContent = "disconnected: reload to reconnect";
    $("status").style.color = "#c66";
  };
  ws.onmessage = (ev) => {
    if (typeof ev.data === "string") {
      const m = JSON.parse(ev.data);
      if (m.type === "hello") hello(m);
      else if (m.type === "frame") nextMeta = m;
      else if (m.type === "error") showError(m.message);
      else if (m.type === "data") showData(m);
      else if (m.type === "movie") movieState(m);
    } else if (nextMeta) {
      onFrame(nextMeta, ev.data);
      nextMeta = null;
    }
  };
}

// ---- input: drag to orbit (shift or right button: pan), wheel to zoom
const box = $("frame-box");
let dragging = null;
let queued = null; // the newest camera not yet sent (one per animation frame)

function queue(c) {
  cam = c;
  if (!queued) requestAnimationFrame(() => { setCamera(queued, true); queued = null; });
  queued = c;
}

box.addEventListener("contextmenu", (e) => e.preventDefault());
box.addEventListener("pointerdown", (e) => {
  if (!cam) return;
  box.focus();
  dragging = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2 };
  box.setPointerCapture(e.pointerId);
  box.style.cursor = "grabbing";
});
box.addEventListener("pointermove", (e) => {
  if (!dragging) return;
  const dx = e.clientX - dragging.x, dy = e.clientY - dragging.y;
  if (!dx && !dy) return;
  dragging.x = e.clientX;
  dragging.y = e.clientY;
  queue(dragging.pan ? pan(cam, dx, dy, img.clientHeight) : orbit(cam, dx, dy));
});
function release() {
  if (!dragging) return;
  dragging = null;
  box.style.cursor = "grab";
  queued = null;
  setCamera(cam, false);
}
box.addEventListener("pointerup", release);
box.addEventListener("pointercancel", release);
box.addEventListener("wheel", (e) => {
  if (!cam) return;
  e.preventDefault();
  queue(zoom(cam, Math.exp(e.deltaY * 0.001)));
}, { passive: false });
box.addEventListener("keydown", (e) => {
  if (!cam) return;
  const axes = { x: 0, y: 1, z: 2 };
  const k = e.key.toLowerCase();
  if (k in axes) setCamera(axisView(cam, axes[k], e.key === k ? 1 : -1), false);
  else if (k === "r" && home) setCamera(home, false);
});

// ---- buttons
function download(url, name) {
  const a = document.createElement("a");
  a.href = url;
  a.download = name;
  document.body.appendChild(a);
  a.click();
  a.remove();
}
$("screenshot").onclick = () => download(`frame.png?token=${token}`, "view.png");
$("save-scene").onclick = () => download(`scene.toml?token=${token}`, "view.toml");
$("record").onclick = () => {
  const b = $("record");
  if (!recording) {
    recording = [];
    b.textContent = "Stop recording";
    b.classList.add("on");
  } else {
    const blob = new Blob([seriesToml(recording)], { type: "application/toml" });
    download(URL.createObjectURL(blob), "series.toml");
    recording = null;
    b.textContent = "Record series";
    b.classList.remove("on");
  }
};

// The movie: the server keeps the full-resolution frames shown while
// recording and writes the movie (ffmpeg) when stopped.
function movieState(m) {
  const b = $("movie");
  movie = m.state;
  if (m.state === "recording") {
    b.textContent = "Stop movie";
    b.classList.add("on");
  } else if (m.state === "writing") {
    b.textContent = `Writing movie (${m.frames} frames)...`;
    b.classList.remove("on");
    b.disabled = true;
  } else if (m.state === "ready") {
    b.textContent = "Record movie";
    b.disabled = false;
    movie = "off";
    stats.movie = m;
    download(`${m.url}?token=${token}`, "view.mp4");
  }
}
$("movie").onclick = () => {
  send({ type: "movie", action: movie === "recording" ? "stop" : "start" });
};

// Test hook (stable): sends a request as the page does.
window.pvrsimSend = send;

connect();
