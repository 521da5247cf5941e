// The transfer-function editor: opacity points over the field's histogram
// on a canvas (x: the normalised scalar s in [0, 1], y: opacity), colour
// per point, colour-map presets, an opacity scale, a log histogram.
// `onChange(rows, interacting)` receives the rows [s, r, g, b, opacity]
// (the opacity scale applied, clamped to 1).

const PRESETS = {
  "cool to warm": [[0, [0.23, 0.299, 0.754]], [0.5, [0.865, 0.865, 0.865]], [1, [0.706, 0.016, 0.15]]],
  viridis: [[0, [0.267, 0.005, 0.329]], [0.25, [0.229, 0.322, 0.546]], [0.5, [0.128, 0.567, 0.551]], [0.75, [0.369, 0.789, 0.383]], [1, [0.993, 0.906, 0.144]]],
  "black body": [[0, [0, 0, 0]], [0.4, [0.9, 0.1, 0.05]], [0.8, [1, 0.85, 0.1]], [1, [1, 1, 1]]],
  grayscale: [[0, [0, 0, 0]], [1, [1, 1, 1]]],
  rainbow: [[0, [0, 0, 1]], [0.25, [0, 1, 1]], [0.5, [0, 1, 0]], [0.75, [1, 1, 0]], [1, [1, 0, 0]]],
};

function presetColour(name, s) {
  const stops = PRESETS[name];
  for (let i = 1; i < stops.length; i++) {
    const [s0, c0] = stops[i - 1], [s1, c1] = stops[i];
    if (s <= s1) {
      const t = s1 > s0 ? (s - s0) / (s1 - s0) : 0;
      return c0.map((v, k) => +(v + (c1[k] - v) * t).toFixed(4));
    }
  }
  return stops[stops.length - 1][1].slice();
}

const hex = (rgb) => "#" + rgb.map((v) => Math.round(Math.min(1, Math.max(0, v)) * 255).toString(16).padStart(2, "0")).join("");
const unhex = (h) => [1, 3, 5].map((i) => +(parseInt(h.slice(i, i + 2), 16) / 255).toFixed(4));

export class TfEditor {
  constructor(canvas, ui, onChange) {
    this.c = canvas;
    this.g = canvas.getContext("2d");
    this.ui = ui;
    this.onChange = onChange;
    this.points = []; // {s, rgb, a}
    this.unit = 1;
    this.hist = [];
    this.scale = 1;
    this.sel = -1;
    this.drag = -1;
    for (const name of Object.keys(PRESETS)) ui.preset.add(new Option(name, name));
    ui.preset.add(new Option("(scene)", "", true, true));
    ui.preset.onchange = () => this.applyPreset(ui.preset.value);
    ui.log.onchange = () => this.draw();
    ui.scale.oninput = () => {
      this.scale = +ui.scale.value;
      ui.scaleValue.textContent = this.scale.toFixed(2);
      this.emit(true);
    };
    ui.scale.onchange = () => this.emit(false);
    ui.colour.oninput = () => {
      if (this.sel >= 0) {
        this.points[this.sel].rgb = unhex(ui.colour.value);
        this.draw();
        this.emit(true);
      }
    };
    ui.colour.onchange = () => this.emit(false);
    canvas.addEventListener("contextmenu", (e) => e.preventDefault());
    canvas.addEventListener("pointerdown", (e) => this.down(e));
    canvas.addEventListener("pointermove", (e) => this.move(e));
    canvas.addEventListener("pointerup", () => this.up());
    canvas.addEventListener("dblclick", (e) => this.addPoint(e));
  }

  set(transfer, histogram) {
    this.points = transfer.points.map((p) => ({ s: p[0], rgb: [p[1], p[2], p[3]], a: p[4] }));
    this.unit = transfer.unit_distance;
    if (histogram) this.hist = histogram;
    this.draw();
  }

  rows() {
    return this.points.map((p) => [p.s, p.rgb[0], p.rgb[1], p.rgb[2], Math.min(1, p.a * this.scale)]);
  }

  transfer() {
    return { points: this.rows(), unit_distance: this.unit };
  }

  emit(interacting) {
    this.onChange(this.transfer(), interacting);
  }

  applyPreset(name) {
    if (!name) return;
    for (const p of this.points) p.rgb = presetColour(name, p.s);
    this.draw();
    this.emit(false);
  }

  xy(e) {
    const r = this.c.getBoundingClientRect();
    const pad = 8;
    const s = (e.clientX - r.left - pad) / (r.width - 2 * pad);
    const a = 1 - (e.clientY - r.top - pad) / (r.height - 2 * pad);
    return [Math.min(1, Math.max(0, s)), Math.min(1, Math.max(0, a))];
  }

  px(s, a) {
    const pad = 8;
    return [pad + s * (this.c.width - 2 * pad), pad + (1 - a) * (this.c.height - 2 * pad)];
  }

  hit(e) {
    const r = this.c.getBoundingClientRect();
    const x = ((e.clientX - r.left) * this.c.width) / r.width;
    const y = ((e.clientY - r.top) * this.c.height) / r.height;
    let best = -1, bd = 81;
    this.points.forEach((p, i) => {
      const [px, py] = this.px(p.s, p.a);
      const d = (px - x) ** 2 + (py - y) ** 2;
      if (d < bd) { bd = d; best = i; }
    });
    return best;
  }

  down(e) {
    const i = this.hit(e);
    if (i < 0) return;
    if ((e.shiftKey || e.button === 2) && this.points.length > 2) {
      this.points.splice(i, 1);
      this.sel = -1;
      this.draw();
      this.emit(false);
      return;
    }
    this.sel = i;
    this.drag = i;
    this.ui.colour.value = hex(this.points[i].rgb);
    this.c.setPointerCapture(e.pointerId);
    this.draw();
  }

  move(e) {
    if (this.drag < 0) return;
    const [s, a] = this.xy(e);
    const i = this.drag, p = this.points[i];
    const lo = i > 0 ? this.points[i - 1].s : 0;
    const hi = i < this.points.length - 1 ? this.points[i + 1].s : 1;
    p.s = +Math.min(hi, Math.max(lo, s)).toFixed(4);
    p.a = +(a / this.scale).toFixed(4);
    this.draw();
    this.emit(true);
  }

  up() {
    if (this.drag >= 0) {
      this.drag = -1;
      this.emit(false);
    }
  }

  addPoint(e) {
    const [s, a] = this.xy(e);
    let i = this.points.findIndex((p) => p.s > s);
    if (i < 0) i = this.points.length;
    const near = this.points[Math.min(i, this.points.length - 1)];
    this.points.splice(i, 0, { s: +s.toFixed(4), rgb: near ? near.rgb.slice() : [1, 1, 1], a: +(a / this.scale).toFixed(4) });
    this.sel = i;
    this.draw();
    this.emit(false);
  }

  draw() {
    const g = this.g, w = this.c.width, h = this.c.height;
    g.clearRect(0, 0, w, h);
    // histogram
    if (this.hist.length) {
      const log = this.ui.log.checked;
      const f = (n) => (log ? Math.log1p(n) : n);
      const top = Math.max(1, ...this.hist.map(f));
      g.fillStyle = "#3a3f44";
      const bw = (w - 16) / this.hist.length;
      this.hist.forEach((n, k) => {
        const bh = (f(n) / top) * (h - 16);
        g.fillRect(8 + k * bw, h - 8 - bh, Math.max(1, bw - 0.5), bh);
      });
    }
    // colour strip along the bottom
    for (let k = 0; k + 1 < this.points.length; k++) {
      const [x0] = this.px(this.points[k].s, 0), [x1] = this.px(this.points[k + 1].s, 0);
      const grad = g.createLinearGradient(x0, 0, x1, 0);
      grad.addColorStop(0, hex(this.points[k].rgb));
      grad.addColorStop(1, hex(this.points[k + 1].rgb));
      g.fillStyle = grad;
      g.fillRect(x0, h - 6, Math.max(1, x1 - x0), 6);
    }
    // opacity polyline and points
    g.strokeStyle = "#eee";
    g.beginPath();
    this.points.forEach((p, i) => {
      const [x, y] = this.px(p.s, Math.min(1, p.a * this.scale));
      i ? g.lineTo(x, y) : g.moveTo(x, y);
    });
    g.stroke();
    this.points.forEach((p, i) => {
      const [x, y] = this.px(p.s, Math.min(1, p.a * this.scale));
      g.fillStyle = hex(p.rgb);
      g.strokeStyle = i === this.sel ? "#ff0" : "#fff";
      g.beginPath();
      g.arc(x, y, 5, 0, 2 * Math.PI);
      g.fill();
      g.stroke();
    });
  }
}
