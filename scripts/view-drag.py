"""Drives `pvrsim view` over its WebSocket as a page would, without a
browser: waits for the first frame, sends 60 interacting camera messages at
60 Hz (the eye turned 0.01 rad about the vertical each), then the release;
prints the frames during the drag, their scales, the median input-to-frame
latency (message sent -> frame received), the render and encode medians and
the full frame after the release.
  target/ci-viewer-venv/bin/python scripts/view-drag.py SCENE [pvrsim view's options]
(websocket-client: Selenium's dependency, in scripts/ci-viewer.sh's venv)."""
import json, os, re, subprocess, sys, time, math, statistics, threading
import websocket
BIN = os.environ.get("PVRSIM_BIN", "target/release/pvrsim")
args = sys.argv[1:]
p = subprocess.Popen([BIN, "view", *args], stdout=subprocess.PIPE, text=True)
line = p.stdout.readline().strip()
m = re.fullmatch(r"view: http://127\.0\.0\.1:(\d+)/\?token=([0-9a-f]+)", line)
port, tok = m.group(1), m.group(2)
t_start = time.time()
ws = websocket.create_connection(f"ws://127.0.0.1:{port}/ws?token={tok}", timeout=600)
frames = []; sent = {}
meta = None; cam = None
def recv():
    global meta, cam
    while True:
        try:
            op, data = ws.recv_data()
        except Exception:
            return
        if op == 1:
            mm = json.loads(data)
            if mm["type"] == "frame":
                meta = mm
                if cam is None: cam = mm["scene"]["camera"]
            elif mm["type"] == "error": print("error", mm)
        elif op == 2 and meta:
            meta["at"] = time.time(); frames.append(meta); meta = None
th = threading.Thread(target=recv, daemon=True); th.start()
while not frames: time.sleep(0.01)
print("first frame after", round(time.time() - t_start, 2), "s render_ms", round(frames[0]["render_ms"]))
time.sleep(0.5)
def rot(c, a):
    t = c["target"]; e = c["eye"]
    off = [e[i] - t[i] for i in range(3)]
    x = off[0] * math.cos(a) + off[2] * math.sin(a); z = -off[0] * math.sin(a) + off[2] * math.cos(a)
    c2 = dict(c); c2["eye"] = [t[0] + x, t[1] + off[1], t[2] + z]; return c2
n0 = len(frames)
N = 60
for k in range(1, N + 1):
    msg = {"type": "view", "camera": rot(cam, 0.01 * k), "interacting": True, "input": k}
    sent[k] = time.time(); ws.send(json.dumps(msg)); time.sleep(1 / 60)
drag_end = time.time()
msg = {"type": "view", "camera": rot(cam, 0.01 * N), "interacting": False, "input": N + 1}
sent[N + 1] = time.time(); ws.send(json.dumps(msg))
t0 = time.time()
while not any(f["input"] == N + 1 and f["scale"] == 1 for f in frames[n0:]):
    time.sleep(0.01)
    if time.time() - t0 > 300: break
rel = time.time() - t0
during = [f for f in frames[n0:] if f["scale"] > 1 or f["input"] <= N]
lat = [1000 * (f["at"] - sent[f["input"]]) for f in during if f["input"] in sent]
print("drag frames", len(during), "scales", sorted({f["scale"] for f in during}),
      "median latency ms", round(statistics.median(lat)) if lat else None,
      "render_ms median", round(statistics.median([f["render_ms"] for f in during]),1) if during else None,
      "encode", round(statistics.median([f["encode_ms"] for f in during]),2) if during else None,
      "full after release s", round(rel, 3), "full render_ms", round(frames[-1]["render_ms"]))
for f in during[:12]: print("  ", f["seq"], f["scale"], f.get("coarse"), f.get("cells"), f["width"], round(f["render_ms"],1), f["input"], round(1000*(f["at"]-sent[f["input"]])))
ws.close(); p.send_signal(2); p.wait(timeout=30)
