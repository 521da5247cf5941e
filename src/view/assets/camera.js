// Camera moves on the scene contract's camera ({eye, target, up,
// projection, height | fov_y_deg}): orbit about the target, zoom, pan,
// the six axis views. Pure functions: each returns a new camera.

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const mul = (a, k) => [a[0] * k, a[1] * k, a[2] * k];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => Math.hypot(a[0], a[1], a[2]);
const unit = (a) => mul(a, 1 / norm(a));

// Rodrigues: v rotated by angle about the unit axis k.
function rotate(v, k, angle) {
  const c = Math.cos(angle), s = Math.sin(angle);
  return add(add(mul(v, c), mul(cross(k, v), s)), mul(k, dot(k, v) * (1 - c)));
}

// The camera frame: forward, right, up (as the renderer computes it).
export function frame(cam) {
  const f = unit(sub(cam.target, cam.eye));
  const r = unit(cross(f, cam.up));
  const u = cross(r, f);
  return { f, r, u };
}

const copy = (cam) => JSON.parse(JSON.stringify(cam));

// Orbit: a drag of (dx, dy) pixels turns the eye about the target
// (0.5 degrees a pixel): horizontally about the view's up, vertically
// about its right axis.
export function orbit(cam, dx, dy) {
  const { r, u } = frame(cam);
  const k = Math.PI / 360;
  let off = sub(cam.eye, cam.target);
  let up = u;
  off = rotate(off, u, -dx * k);
  const r2 = rotate(r, u, -dx * k);
  off = rotate(off, r2, -dy * k);
  up = rotate(up, r2, -dy * k);
  const c = copy(cam);
  c.eye = add(cam.target, off);
  c.up = up;
  return c;
}

// Zoom by a factor (< 1 closer): the orthographic height, or the eye's
// distance for a perspective camera.
export function zoom(cam, factor) {
  const c = copy(cam);
  if (c.projection === "orthographic") {
    c.height = cam.height * factor;
  } else {
    c.eye = add(cam.target, mul(sub(cam.eye, cam.target), factor));
  }
  return c;
}

// World size of one displayed pixel at the target.
function worldPerPixel(cam, displayHeight) {
  if (cam.projection === "orthographic") return cam.height / displayHeight;
  const d = norm(sub(cam.target, cam.eye));
  return (2 * d * Math.tan((cam.fov_y_deg * Math.PI) / 360)) / displayHeight;
}

// Pan: the eye and target moved together so the scene follows the pointer.
export function pan(cam, dx, dy, displayHeight) {
  const { r, u } = frame(cam);
  const w = worldPerPixel(cam, displayHeight);
  const shift = add(mul(r, -dx * w), mul(u, dy * w));
  const c = copy(cam);
  c.eye = add(cam.eye, shift);
  c.target = add(cam.target, shift);
  return c;
}

// One of the six axis views: the eye on the axis through the target at
// its current distance (sign +1: on the positive side, looking back).
export function axisView(cam, axis, sign) {
  const d = norm(sub(cam.eye, cam.target));
  const dir = [0, 0, 0];
  dir[axis] = sign;
  const c = copy(cam);
  c.eye = add(cam.target, mul(dir, d));
  c.up = axis === 1 ? [0, 0, -sign] : [0, 1, 0];
  return c;
}
