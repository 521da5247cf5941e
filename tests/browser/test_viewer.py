"""`pvrsim view` in a real browser (Debian's chromium + chromedriver, driven
by Selenium): the page loads, draws its first frame, a drag across the frame
shows reduced-resolution frames (data-scale > 1) and the release a
full-resolution one (data-scale = 1); `pvrsim render` of /scene.toml gives
/frame.png bit for bit (in this process, and over 4 worker processes with
--canonical --ert 1 against `pvrsim cluster`); the field selector and the
time-step slider; a grid scene; the token check;
a malformed message shown in the page while the server keeps serving.

Run by scripts/ci-viewer.sh (which installs chromium when root and skips
when there is none). Environment: PVRSIM_BIN (default target/release/pvrsim),
PVRSIM_VIEWER_SCENE (default ../shared/data/aorta-view-b.toml, else the
bundled tests/data/aorta-small-view-b.toml), PVRSIM_VIEWER_SIZE (default
512), PVRSIM_VIEWER_SCREENSHOT (a PNG path: the page's screenshot),
PVRSIM_VIEWER_REPORT (a JSON path: measured latency, fps, idle CPU).
"""

import json
import os
import re
import shutil
import statistics
import subprocess
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

ROOT = Path(__file__).resolve().parents[2]
BIN = os.environ.get("PVRSIM_BIN", str(ROOT / "target/release/pvrsim"))
SHARED_B = ROOT.parent / "shared/data/aorta-view-b.toml"
SCENE = os.environ.get(
    "PVRSIM_VIEWER_SCENE",
    str(SHARED_B if SHARED_B.exists() else ROOT / "tests/data/aorta-small-view-b.toml"),
)
SIZE = os.environ.get("PVRSIM_VIEWER_SIZE", "512")
ISCALE = os.environ.get("PVRSIM_VIEWER_ISCALE", "auto")
REPORT = {}


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        p = shutil.which(name)
        if p:
            return p
    return None


def chromedriver():
    return shutil.which("chromedriver") or (
        "/usr/lib/chromium/chromedriver" if Path("/usr/lib/chromium/chromedriver").exists() else None
    )


if not chromium() or not chromedriver():
    pytest.skip("no chromium/chromedriver on this machine (scripts/ci-viewer.sh installs them as root)",
                allow_module_level=True)


class Viewer:
    """A `pvrsim view` process and the URL it printed."""

    def __init__(self, *args):
        self.proc = subprocess.Popen([BIN, "view", *args], stdout=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline().strip()
        m = re.fullmatch(r"view: (http://127\.0\.0\.1:(\d+))/\?token=([0-9a-f]+)", line)
        assert m, f"the first line is the URL: {line!r}"
        self.base, self.port, self.token = m.group(1), int(m.group(2)), m.group(3)
        self.url = f"{self.base}/?token={self.token}"

    def get(self, path, token=True):
        sep = "&" if "?" in path else "?"
        url = self.base + path + (f"{sep}token={self.token}" if token else "")
        try:
            with urllib.request.urlopen(url, timeout=60) as r:
                return r.status, r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.read()

    def close(self):
        self.proc.send_signal(2)  # Ctrl-C
        try:
            assert self.proc.wait(timeout=15) == 0, "Ctrl-C ends the viewer with exit 0"
        finally:
            if self.proc.poll() is None:
                self.proc.kill()


@pytest.fixture(scope="module")
def browser():
    opts = webdriver.ChromeOptions()
    opts.binary_location = chromium()
    profile = tempfile.mkdtemp(prefix="pvrsim-chromium-")
    for a in ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              f"--user-data-dir={profile}", "--window-size=1400,900"]:
        opts.add_argument(a)
    d = webdriver.Chrome(service=Service(executable_path=chromedriver()), options=opts)
    d.set_script_timeout(60)
    yield d
    d.quit()
    shutil.rmtree(profile, ignore_errors=True)
    if os.environ.get("PVRSIM_VIEWER_REPORT"):
        Path(os.environ["PVRSIM_VIEWER_REPORT"]).write_text(json.dumps(REPORT, indent=2))


def frame_attr(d):
    el = d.find_element(By.ID, "frame")
    return int(el.get_attribute("data-seq") or 0), int(el.get_attribute("data-scale") or 0)


def wait_for(cond, timeout=120, what="condition"):
    t = time.time()
    while time.time() - t < timeout:
        v = cond()
        if v:
            return v
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


def wait_full_frame_after(d, seq, timeout=120):
    return wait_for(lambda: (lambda s: s if s[0] > seq and s[1] == 1 else None)(frame_attr(d)),
                    timeout, f"a full-resolution frame after frame {seq}")


def drag(d, steps=40, dx=6, pause=0.025):
    """Presses on the frame, moves `steps` times by dx pixels, releases;
    returns the page's frames shown between the press and the release."""
    el = d.find_element(By.ID, "frame")
    before = d.execute_script("return window.pvrsimStats.frames.length")
    chain = ActionChains(d, duration=0)
    chain.move_to_element(el).click_and_hold()
    for _ in range(steps):
        chain.move_by_offset(dx, 0).pause(pause)
    chain.perform()
    during = d.execute_script("return window.pvrsimStats.frames.slice(arguments[0])", before)
    ActionChains(d, duration=0).release().perform()
    return during


def same_as_render(v, tmp, command, *options):
    """`pvrsim COMMAND` of /scene.toml (with the options) equals /frame.png."""
    st, toml = v.get("/scene.toml")
    assert st == 200
    st, png = v.get("/frame.png")
    assert st == 200 and png[1:4] == b"PNG"
    scene = Path(tmp) / "view.toml"
    scene.write_bytes(toml)
    out = Path(tmp) / "render.png"
    subprocess.run([BIN, command, str(scene), *options, "-o", str(out)], check=True,
                   stdout=subprocess.DEVNULL)
    assert out.read_bytes() == png, f"pvrsim {command} of /scene.toml gives /frame.png bit for bit"


def test_drag_shows_reduced_frames_then_a_full_one_equal_to_pvrsim_render(browser, tmp_path):
    v = Viewer(SCENE, "--width", SIZE, "--height", SIZE, "--interactive-scale", ISCALE)
    try:
        d = browser
        d.get(v.url)
        wait_for(lambda: frame_attr(d)[0] >= 1 and frame_attr(d)[1] == 1, what="the first frame")
        during = drag(d)
        assert during, "frames during the drag"
        if ISCALE != "1":
            assert any(f["scale"] > 1 for f in during), f"reduced frames during the drag: {during}"
        seq = max([f["seq"] for f in during] + [frame_attr(d)[0]])
        t0 = time.time()
        wait_full_frame_after(d, seq - 1)
        release_s = time.time() - t0
        wait_for(lambda: frame_attr(d)[1] == 1, what="scale 1 after the release")
        assert frame_attr(d)[1] == 1
        lat = d.execute_script("return window.pvrsimStats.latencies")
        moving = [l["ms"] for l in lat if l["scale"] > 1]
        times = [f["at"] for f in during]
        fps = (len(times) - 1) / ((times[-1] - times[0]) / 1000) if len(times) > 1 else 0
        state = json.loads(v.get("/state.json")[1])
        REPORT["threads"] = {
            "scene": SCENE, "size": SIZE, "interactive_scale": ISCALE,
            "drag_frames": len(during), "drag_scales": sorted({f["scale"] for f in during}),
            "drag_coarse_frames": sum(1 for f in during if f.get("coarse")),
            "median_latency_ms_moving": statistics.median(moving) if moving else None,
            "fps_while_dragging": fps, "full_frame_after_release_s": release_s,
            "full_render_ms": state["render_ms"],
            "encode_ms_jpeg_median": statistics.median([f["encode_ms"] for f in during]),
            "encode_ms_png_full": state["encode_ms"],
        }
        print(json.dumps(REPORT["threads"]))
        same_as_render(v, tmp_path, "render")
        if os.environ.get("PVRSIM_VIEWER_IDLE_S"):
            REPORT["idle"] = idle_cpu(v, d, float(os.environ["PVRSIM_VIEWER_IDLE_S"]))
        shot = os.environ.get("PVRSIM_VIEWER_SCREENSHOT")
        if shot and not os.environ.get("PVRSIM_VIEWER_SHOT_CLUSTER"):
            d.save_screenshot(shot)
    finally:
        v.close()


def cpu_seconds(pids):
    total = 0.0
    tick = os.sysconf("SC_CLK_TCK")
    for p in pids:
        try:
            f = Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()
            total += (int(f[11]) + int(f[12])) / tick
        except FileNotFoundError:
            pass
    return total


def browser_pids(d):
    root = d.service.process.pid
    out = subprocess.run(["ps", "-e", "-o", "pid=,ppid="], capture_output=True, text=True).stdout
    kids = {}
    for line in out.split("\n"):
        if line.strip():
            p, pp = map(int, line.split())
            kids.setdefault(pp, []).append(p)
    pids, todo = [], [root]
    while todo:
        p = todo.pop()
        pids.append(p)
        todo += kids.get(p, [])
    return pids


def idle_cpu(v, d, seconds):
    """CPU share of the server and of the browser (all its processes) over
    `seconds` of no input, with the page open."""
    time.sleep(1.0)
    seq = frame_attr(d)[0]
    sp, bp = [v.proc.pid], browser_pids(d)
    s0, b0, t0 = cpu_seconds(sp), cpu_seconds(bp), time.time()
    time.sleep(seconds)
    s1, b1, t1 = cpu_seconds(sp), cpu_seconds(bp), time.time()
    assert frame_attr(d)[0] == seq, "no frame is drawn while nothing changes"
    return {"seconds": t1 - t0, "server_cpu_percent": 100 * (s1 - s0) / (t1 - t0),
            "browser_cpu_percent": 100 * (b1 - b0) / (t1 - t0), "frames_while_idle": 0}


def test_cluster_of_4_worker_processes_equals_pvrsim_cluster(browser, tmp_path):
    opts = ["--canonical", "--ert", "1"]
    v = Viewer(SCENE, "--width", SIZE, "--height", SIZE, "--nodes", "4", "--transport", "processes",
               "--interactive-scale", ISCALE, *opts)
    try:
        d = browser
        d.get(v.url)
        wait_for(lambda: frame_attr(d)[0] >= 1 and frame_attr(d)[1] == 1, what="the first frame",
                 timeout=300)
        during = drag(d, steps=40, dx=6, pause=0.025)
        if ISCALE == "auto":
            assert any(f["scale"] > 1 for f in during), f"reduced frames during the drag: {during}"
        seq = max([f["seq"] for f in during] + [frame_attr(d)[0]])
        t0 = time.time()
        wait_full_frame_after(d, seq - 1, timeout=300)
        release_s = time.time() - t0
        wait_for(lambda: frame_attr(d)[1] == 1, what="scale 1 after the release")
        bars = d.find_elements(By.CSS_SELECTOR, "#node-bars .node")
        assert len(bars) == 5, "a header and one row of bars per node"
        lat = d.execute_script("return window.pvrsimStats.latencies")
        moving = [l["ms"] for l in lat if l["scale"] > 1]
        times = [f["at"] for f in during]
        state = json.loads(v.get("/state.json")[1])
        REPORT["processes4"] = {
            "interactive_scale": ISCALE,
            "drag_frames": len(during), "drag_scales": sorted({f["scale"] for f in during}),
            "drag_coarse_frames": sum(1 for f in during if f.get("coarse")),
            "median_latency_ms_moving": statistics.median(moving) if moving else None,
            "fps_while_dragging":
                (len(times) - 1) / ((times[-1] - times[0]) / 1000) if len(times) > 1 else 0,
            "full_frame_after_release_s": release_s, "full_render_ms": state["render_ms"],
        }
        print(json.dumps(REPORT["processes4"]))
        shot = os.environ.get("PVRSIM_VIEWER_SCREENSHOT")
        if shot and os.environ.get("PVRSIM_VIEWER_SHOT_CLUSTER"):
            d.save_screenshot(shot)
        same_as_render(v, tmp_path, "cluster", "--nodes", "4", "--transport", "processes", *opts)
    finally:
        v.close()


def test_field_and_time_step_in_the_page(browser, tmp_path):
    """The field selector and the time-step slider: another field changes
    the histogram and the frame, /scene.toml names it and `pvrsim render`
    of it gives /frame.png; the movie button says what it needs."""
    shutil.copy(ROOT / "tests/data/aorta-small.vtk", tmp_path / "step1.vtk")
    series = tmp_path / "steps.toml"
    series.write_text('[[frame]]\n[[frame]]\nmesh = "step1.vtk"\n')
    v = Viewer(str(ROOT / "tests/data/aorta-small-view-b.toml"), "--width", "200", "--height", "160",
               "--series", str(series))
    try:
        d = browser
        d.get(v.url)
        wait_for(lambda: frame_attr(d)[0] >= 1 and frame_attr(d)[1] == 1, what="the first frame")
        names = d.execute_script(
            "return [...document.getElementById('field-select').options].map(o => o.value)")
        assert {"speed", "pressure", "potential"} <= set(names), names
        assert d.find_element(By.ID, "steps").is_displayed(), "the time-step slider is shown"
        hist = d.execute_script("return document.getElementById('field').textContent")
        seq = frame_attr(d)[0]
        d.execute_script("""const f = document.getElementById('field-select');
                            f.value = 'pressure'; f.dispatchEvent(new Event('change'));""")
        wait_full_frame_after(d, seq)
        wait_for(lambda: d.execute_script("return document.getElementById('field').textContent") != hist,
                 30, "the range of the new field")
        st, toml = v.get("/scene.toml")
        assert b'field = "pressure"' in toml, toml
        same_as_render(v, tmp_path, "render")
        seq = frame_attr(d)[0]
        d.execute_script("""const s = document.getElementById('step');
                            s.value = '1'; s.dispatchEvent(new Event('input'));""")
        wait_full_frame_after(d, seq)
        assert "step1.vtk" in d.find_element(By.ID, "step-name").text
        st, toml = v.get("/scene.toml")
        assert b"step1.vtk" in toml, toml
        # An unknown field from the page's own socket: shown, serving goes on.
        d.execute_script("window.pvrsimSend({type: 'data', field: 'temperature'})")
        err = wait_for(lambda: d.find_element(By.ID, "error").text, 30, "the error shown")
        assert "unknown field" in err
        if not shutil.which("ffmpeg"):
            d.find_element(By.ID, "movie").click()
            err = wait_for(lambda: "ffmpeg" in d.find_element(By.ID, "error").text, 30,
                           "the movie's ffmpeg message")
    finally:
        v.close()


def test_grid_scene(browser, tmp_path):
    subprocess.run([BIN, "demo", "--cells", "2000", "--nodes", "0", "--out-dir", str(tmp_path)],
                   check=True, stdout=subprocess.DEVNULL)
    v = Viewer(str(tmp_path / "hydrogen.toml"), "--width", "256", "--height", "256")
    try:
        d = browser
        d.get(v.url)
        wait_for(lambda: frame_attr(d)[0] >= 1 and frame_attr(d)[1] == 1, what="the first frame")
        during = drag(d, steps=10)
        seq = max([f["seq"] for f in during] + [frame_attr(d)[0]])
        wait_full_frame_after(d, seq - 1)
        same_as_render(v, tmp_path, "render")
    finally:
        v.close()


def test_token_and_malformed_message(browser):
    v = Viewer("tests/data/aorta-small-view-b.toml")
    try:
        d = browser
        d.get(v.base + "/")
        assert "403" in d.find_element(By.TAG_NAME, "body").text
        assert not d.find_elements(By.ID, "frame")
        d.get(v.base + "/?token=wrong")
        assert "403" in d.find_element(By.TAG_NAME, "body").text
        for path in ["/frame.png", "/scene.toml", "/state.json", "/assets/app.js"]:
            assert v.get(path, token=False)[0] == 403, path
        d.get(v.url)
        wait_for(lambda: frame_attr(d)[0] >= 1, what="the first frame")
        # A malformed message from this page's origin: answered with an error.
        reply = d.execute_async_script(
            """const done = arguments[arguments.length - 1];
               const ws = new WebSocket(`ws://${location.host}/ws${location.search}`);
               ws.onopen = () => ws.send('{"type": "view", "camera": {"eye": [0, 0');
               ws.onmessage = (e) => { if (typeof e.data === 'string') {
                   const m = JSON.parse(e.data); if (m.type === 'error') { ws.close(); done(m.message); } } };""")
        assert "malformed" in reply
        # An impossible camera through the page's own socket: shown in the page.
        d.execute_script("""window.pvrsimSend({type: 'view', camera: {eye: [1, 2, 3], target: [1, 2, 3],
                            up: [0, 1, 0], projection: 'orthographic', height: 5}})""")
        err = wait_for(lambda: d.find_element(By.ID, "error").text, 30, "the error shown")
        assert "camera.target" in err
        # The server keeps serving.
        seq = frame_attr(d)[0]
        drag(d, steps=5)
        wait_full_frame_after(d, seq)
    finally:
        v.close()
