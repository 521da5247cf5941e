//! `pvrsim view`'s server, driven as a page would drive it (a raw HTTP
//! client and a WebSocket client): the token check, a malformed message
//! answered with an error while the server keeps serving, reduced frames
//! during a drag and a full one after it, and `/scene.toml` rendered by
//! `pvrsim render` giving `/frame.png` bit for bit. The real-browser test
//! is `scripts/ci-viewer.sh`.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::Message;

const BIN: &str = env!("CARGO_BIN_EXE_pvrsim");

/// A `pvrsim view` process and the URL it printed.
struct Server {
    child: Child,
    port: u16,
    token: String,
}

impl Server {
    fn start(args: &[&str]) -> Server {
        let mut child = Command::new(BIN)
            .arg("view")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("pvrsim view starts");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let url = line
            .trim()
            .strip_prefix("view: http://127.0.0.1:")
            .unwrap_or_else(|| panic!("the first line is the URL: {line:?}"));
        let (port, token) = url.split_once("/?token=").expect("?token= in the URL");
        Server {
            child,
            port: port.parse().unwrap(),
            token: token.to_string(),
        }
    }

    /// GET `path` (with the query given): status and body.
    fn get(&self, path: &str) -> (u16, Vec<u8>) {
        let mut s = TcpStream::connect(("127.0.0.1", self.port)).unwrap();
        write!(
            s,
            "GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n"
        )
        .unwrap();
        let mut all = Vec::new();
        s.read_to_end(&mut all).unwrap();
        let split = all
            .windows(4)
            .position(|w| w == b"\r\n\r\n")
            .expect("a header");
        let head = String::from_utf8_lossy(&all[..split]).to_string();
        let status = head.split(' ').nth(1).unwrap().parse().unwrap();
        assert!(
            !head
                .to_ascii_lowercase()
                .contains("transfer-encoding: chunked"),
            "{head}"
        );
        (status, all[split + 4..].to_vec())
    }

    fn ws_url(&self) -> String {
        format!("ws://127.0.0.1:{}/ws?token={}", self.port, self.token)
    }

    /// Ctrl-C: the server ends cleanly.
    fn interrupt(mut self) {
        unsafe { libc::kill(self.child.id() as i32, libc::SIGINT) };
        let t = Instant::now();
        loop {
            if let Some(st) = self.child.try_wait().unwrap() {
                assert!(st.success(), "Ctrl-C ends the viewer with exit 0: {st}");
                return;
            }
            assert!(
                t.elapsed() < Duration::from_secs(10),
                "the viewer did not stop within 10 s of Ctrl-C"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

type Ws =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// The next message: JSON text, with the binary frame that follows a
/// `frame` description.
async fn next(ws: &mut Ws) -> (serde_json::Value, Option<Vec<u8>>) {
    loop {
        let m = tokio::time::timeout(Duration::from_secs(60), ws.next())
            .await
            .expect("a message within 60 s")
            .expect("the socket stays open")
            .unwrap();
        if let Message::Text(t) = m {
            let v: serde_json::Value = serde_json::from_str(t.as_str()).unwrap();
            if v["type"] == "frame" {
                match ws.next().await.unwrap().unwrap() {
                    Message::Binary(b) => return (v, Some(b.to_vec())),
                    other => panic!("a binary frame after its description, got {other:?}"),
                }
            }
            return (v, None);
        }
    }
}

/// The next frame description (skipping other messages), with its bytes.
async fn next_frame(ws: &mut Ws) -> (serde_json::Value, Vec<u8>) {
    loop {
        if let (v, Some(b)) = next(ws).await {
            return (v, b);
        }
    }
}

fn camera_msg(cam: &serde_json::Value, turn_deg: f64, interacting: bool, input: u64) -> String {
    let mut c = cam.clone();
    let (eye, target) = (&cam["eye"], &cam["target"]);
    let d: Vec<f64> = (0..3)
        .map(|k| eye[k].as_f64().unwrap() - target[k].as_f64().unwrap())
        .collect();
    let a = turn_deg.to_radians();
    // about the y axis
    let (x, z) = (
        d[0] * a.cos() + d[2] * a.sin(),
        -d[0] * a.sin() + d[2] * a.cos(),
    );
    c["eye"] = serde_json::json!([
        target[0].as_f64().unwrap() + x,
        target[1].as_f64().unwrap() + d[1],
        target[2].as_f64().unwrap() + z
    ]);
    serde_json::json!({"type": "view", "camera": c, "interacting": interacting, "input": input})
        .to_string()
}

#[test]
fn the_token_is_required_everywhere() {
    let s = Server::start(&["tests/data/aorta-small-view-b.toml"]);
    for path in [
        "/",
        "/frame.png",
        "/scene.toml",
        "/state.json",
        "/assets/app.js",
        "/ws",
    ] {
        assert_eq!(s.get(path).0, 403, "{path} without a token");
        let wrong = format!("{path}?token=0{}", &s.token[1..]);
        assert_eq!(s.get(&wrong).0, 403, "{path} with a wrong token");
    }
    let (st, body) = s.get(&format!("/?token={}", s.token));
    assert_eq!(st, 200);
    assert!(String::from_utf8_lossy(&body).contains("id=\"frame\""));
    let (st, _) = s.get(&format!("/assets/app.js?token={}", s.token));
    assert_eq!(st, 200);
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let bad = format!("ws://127.0.0.1:{}/ws?token=nope", s.port);
        assert!(tokio_tungstenite::connect_async(bad).await.is_err());
    });
    s.interrupt();
}

#[test]
fn drag_then_release_and_the_frame_equals_pvrsim_render_of_the_scene() {
    let s = Server::start(&[
        "tests/data/aorta-small-view-b.toml",
        "--width",
        "160",
        "--height",
        "120",
        "--interactive-scale",
        "4",
    ]);
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let (mut ws, _) = tokio_tungstenite::connect_async(s.ws_url()).await.unwrap();
        let (hello, _) = next(&mut ws).await;
        assert_eq!(hello["type"], "hello", "{hello}");
        assert_eq!(hello["histogram"].as_array().unwrap().len(), 128);
        let (first, png) = next_frame(&mut ws).await;
        assert_eq!(first["scale"], 1, "{first}");
        assert_eq!(&png[1..4], b"PNG");
        let cam = first["scene"]["camera"].clone();

        // A malformed message and a NaN-free but impossible camera: errors,
        // and the server keeps serving.
        ws.send(Message::Text("{not json".into())).await.unwrap();
        let (e, _) = next(&mut ws).await;
        assert_eq!(e["type"], "error", "{e}");
        assert!(e["message"].as_str().unwrap().contains("malformed"), "{e}");
        let mut same = cam.clone();
        same["target"] = same["eye"].clone();
        let m = serde_json::json!({"type": "view", "camera": same, "input": 1});
        ws.send(Message::Text(m.to_string().into())).await.unwrap();
        let (e, _) = next(&mut ws).await;
        assert_eq!(e["type"], "error", "{e}");
        assert!(
            e["message"].as_str().unwrap().contains("camera.target"),
            "{e}"
        );

        // A drag: reduced frames, then a full one after the release.
        let mut reduced = 0;
        for k in 1..=6u64 {
            let m = camera_msg(&cam, 4.0 * k as f64, true, 10 + k);
            ws.send(Message::Text(m.into())).await.unwrap();
            let (f, jpeg) = next_frame(&mut ws).await;
            assert_eq!(f["scale"], 4, "{f}");
            assert_eq!(
                (f["width"].as_u64(), f["height"].as_u64()),
                (Some(40), Some(30))
            );
            assert_eq!(&jpeg[..2], &[0xff, 0xd8], "JPEG while moving");
            reduced += 1;
        }
        assert_eq!(reduced, 6);
        // No release message: the full frame follows the settle time.
        let (f, png) = next_frame(&mut ws).await;
        assert_eq!(f["scale"], 1, "{f}");
        assert_eq!(
            (f["width"].as_u64(), f["height"].as_u64()),
            (Some(160), Some(120))
        );

        // What /frame.png and /scene.toml serve is that frame.
        let (st, served) = s.get(&format!("/frame.png?token={}", s.token));
        assert_eq!(st, 200);
        let pixels = |b: &[u8]| image::load_from_memory(b).unwrap().to_rgb8().into_raw();
        assert_eq!(
            pixels(&served),
            pixels(&png),
            "/frame.png is the last full frame"
        );
        let (st, toml) = s.get(&format!("/scene.toml?token={}", s.token));
        assert_eq!(st, 200);
        let (st, state) = s.get(&format!("/state.json?token={}", s.token));
        assert_eq!(st, 200);
        let state: serde_json::Value = serde_json::from_slice(&state).unwrap();
        assert_eq!(state["seq"], f["seq"], "{state}");
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("view.toml");
        std::fs::write(&scene, &toml).unwrap();
        let out = dir.path().join("render.png");
        let st = Command::new(BIN)
            .args([
                "render",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ])
            .stdout(Stdio::null())
            .status()
            .unwrap();
        assert!(st.success());
        assert_eq!(
            std::fs::read(&out).unwrap(),
            served,
            "pvrsim render of /scene.toml gives /frame.png bit for bit"
        );
        // The turned camera is in the scene (not the start camera).
        assert!(!String::from_utf8_lossy(&toml).contains("eye        = [-2.5, 0.0, 232.7]"));

        // A second page sees frames too; the last input wins.
        let (mut ws2, _) = tokio_tungstenite::connect_async(s.ws_url()).await.unwrap();
        let _ = next(&mut ws2).await; // hello
        let _ = next_frame(&mut ws2).await; // the last frame
        let m = camera_msg(&cam, -30.0, false, 99);
        ws2.send(Message::Text(m.into())).await.unwrap();
        let (f1, _) = next_frame(&mut ws).await;
        let (f2, _) = next_frame(&mut ws2).await;
        assert_eq!(f1["seq"], f2["seq"]);
        assert_eq!(f1["input"], 99);
    });
    s.interrupt();
}

#[test]
fn a_grid_scene_is_served() {
    let dir = tempfile::tempdir().unwrap();
    let st = Command::new(BIN)
        .args([
            "demo",
            "--cells",
            "2000",
            "--nodes",
            "0",
            "--out-dir",
            dir.path().to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(st.success());
    let scene = dir.path().join("hydrogen.toml");
    assert!(scene.exists(), "pvrsim demo writes hydrogen.toml");
    let s = Server::start(&[scene.to_str().unwrap(), "--width", "96", "--height", "96"]);
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let (mut ws, _) = tokio_tungstenite::connect_async(s.ws_url()).await.unwrap();
        let (hello, _) = next(&mut ws).await;
        assert!(hello["renderers"]
            .as_array()
            .unwrap()
            .iter()
            .any(|r| r == "shearwarp"));
        let (f, _) = next_frame(&mut ws).await;
        assert_eq!(f["scale"], 1);
        let m = serde_json::json!({"type": "options", "renderer": "cell"});
        ws.send(Message::Text(m.to_string().into())).await.unwrap();
        let (e, _) = next(&mut ws).await;
        assert_eq!(e["type"], "error", "{e}");
        assert!(
            e["message"].as_str().unwrap().contains("does not draw"),
            "{e}"
        );
        let m = serde_json::json!({"type": "options", "renderer": "slice3d"});
        ws.send(Message::Text(m.to_string().into())).await.unwrap();
        let (f, _) = next_frame(&mut ws).await;
        assert_eq!(f["scale"], 1, "{f}");
    });
    let (_, png) = s.get(&format!("/frame.png?token={}", s.token));
    let (_, toml) = s.get(&format!("/scene.toml?token={}", s.token));
    let p = dir.path().join("view.toml");
    std::fs::write(&p, toml).unwrap();
    let out = dir.path().join("r.png");
    let st = Command::new(BIN)
        .args([
            "render",
            p.to_str().unwrap(),
            "--renderer",
            "slice3d",
            "-o",
            out.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(st.success());
    assert_eq!(std::fs::read(&out).unwrap(), png);
    s.interrupt();
}
