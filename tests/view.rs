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
        Server::start_with_path(args, None)
    }

    /// [`Server::start`] with `PATH` set to `path` (a stand-in ffmpeg).
    fn start_with_path(args: &[&str], path: Option<&str>) -> Server {
        let mut cmd = Command::new(BIN);
        if let Some(p) = path {
            cmd.env("PATH", p);
        }
        let mut child = cmd
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

/// `pvrsim render` (or `pvrsim cluster` with `opts`) of the scene
/// `/scene.toml` serves gives `/frame.png` bit for bit; the scene's text.
fn same_as_command(s: &Server, dir: &std::path::Path, name: &str, command: &[&str]) -> String {
    let (st, png) = s.get(&format!("/frame.png?token={}", s.token));
    assert_eq!(st, 200);
    let (st, toml) = s.get(&format!("/scene.toml?token={}", s.token));
    assert_eq!(st, 200);
    let scene = dir.join(format!("{name}.toml"));
    std::fs::write(&scene, &toml).unwrap();
    let out = dir.join(format!("{name}.png"));
    let st = Command::new(BIN)
        .arg(command[0])
        .arg(&scene)
        .args(&command[1..])
        .arg("-o")
        .arg(&out)
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(st.success());
    assert_eq!(
        std::fs::read(&out).unwrap(),
        png,
        "{command:?} of /scene.toml gives /frame.png bit for bit"
    );
    String::from_utf8(toml).unwrap()
}

/// Sends a message and returns the next message that is not a frame
/// (a `data` note or an error).
async fn answer(ws: &mut Ws, m: serde_json::Value) -> serde_json::Value {
    ws.send(Message::Text(m.to_string().into())).await.unwrap();
    loop {
        let (v, bytes) = next(ws).await;
        if bytes.is_none() {
            return v;
        }
    }
}

/// The field and time-step choice: the data's fields and the series' time
/// steps in `hello`; another field changes the histogram and the frame,
/// `/scene.toml` names it and reproduces `/frame.png` (in this process and
/// on 2 worker processes against `pvrsim cluster`); an unknown field
/// and a time step that does not exist are refused with a message while
/// the server keeps serving.
#[test]
fn fields_and_time_steps_are_chosen_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy("tests/data/aorta-small.vtk", dir.path().join("step1.vtk")).unwrap();
    let series = dir.path().join("steps.toml");
    std::fs::write(&series, "[[frame]]\n[[frame]]\nmesh = \"step1.vtk\"\n").unwrap();
    let size = ["--width", "96", "--height", "72"];
    for cluster in [false, true] {
        let mut args = vec![
            "tests/data/aorta-small-view-b.toml",
            "--series",
            series.to_str().unwrap(),
        ];
        args.extend(size);
        if cluster {
            args.extend([
                "--nodes",
                "2",
                "--transport",
                "processes",
                "--canonical",
                "--ert",
                "1",
            ]);
        }
        let s = Server::start(&args);
        let rt = tokio::runtime::Runtime::new().unwrap();
        rt.block_on(async {
            let (mut ws, _) = tokio_tungstenite::connect_async(s.ws_url()).await.unwrap();
            let (hello, _) = next(&mut ws).await;
            assert_eq!(hello["field"], "speed", "{hello}");
            let fields: Vec<&str> = hello["fields"]
                .as_array()
                .unwrap()
                .iter()
                .map(|f| f.as_str().unwrap())
                .collect();
            for f in ["speed", "pressure", "potential"] {
                assert!(fields.contains(&f), "{fields:?}");
            }
            assert_eq!(
                hello["steps"],
                serde_json::json!(["aorta-small.vtk", "step1.vtk"])
            );
            let (first, _) = next_frame(&mut ws).await;

            // Another field: a data note (its histogram), then its frame.
            let d = answer(
                &mut ws,
                serde_json::json!({"type": "data", "field": "pressure"}),
            )
            .await;
            assert_eq!(d["type"], "data", "{d}");
            assert_eq!(d["field"], "pressure");
            assert_ne!(
                d["histogram"], hello["histogram"],
                "the histogram follows the field"
            );
            let (f, png) = next_frame(&mut ws).await;
            assert_eq!(
                (f["scale"].as_u64(), f["field"].as_str()),
                (Some(1), Some("pressure"))
            );
            assert_ne!(f["seq"], first["seq"]);
            let (_, speed_png) = (first, png.clone());
            let command: &[&str] = if cluster {
                &[
                    "cluster",
                    "--nodes",
                    "2",
                    "--transport",
                    "processes",
                    "--canonical",
                    "--ert",
                    "1",
                    "--no-baselines",
                ]
            } else {
                &["render"]
            };
            let toml = same_as_command(&s, dir.path(), "pressure", command);
            assert!(toml.contains("field = \"pressure\""), "{toml}");

            // Refused: an unknown field, a time step that does not exist.
            let e = answer(
                &mut ws,
                serde_json::json!({"type": "data", "field": "temperature"}),
            )
            .await;
            assert_eq!(e["type"], "error", "{e}");
            assert!(
                e["message"]
                    .as_str()
                    .unwrap()
                    .contains("unknown field \"temperature\""),
                "{e}"
            );
            let e = answer(&mut ws, serde_json::json!({"type": "data", "step": 2})).await;
            assert_eq!(e["type"], "error", "{e}");
            assert!(
                e["message"]
                    .as_str()
                    .unwrap()
                    .contains("time step 2 does not exist"),
                "{e}"
            );

            // The server keeps serving: time step 1 (the same data in
            // another file: the same image), named by /scene.toml.
            let d = answer(&mut ws, serde_json::json!({"type": "data", "step": 1})).await;
            assert_eq!(
                (d["step"].as_u64(), d["field"].as_str()),
                (Some(1), Some("pressure")),
                "{d}"
            );
            let (f, png) = next_frame(&mut ws).await;
            assert_eq!(f["step"], 1, "{f}");
            assert_eq!(png, speed_png, "the time step holds the same data");
            let toml = same_as_command(&s, dir.path(), "step1", command);
            assert!(toml.contains("step1.vtk"), "{toml}");
            let (st, state) = s.get(&format!("/state.json?token={}", s.token));
            assert_eq!(st, 200);
            let state: serde_json::Value = serde_json::from_slice(&state).unwrap();
            assert_eq!(
                (state["step"].as_u64(), state["field"].as_str()),
                (Some(1), Some("pressure"))
            );
        });
        s.interrupt();
    }
}

/// A grid has one field: the selector lists it; another is refused.
#[test]
fn a_grid_lists_its_one_field() {
    let dir = tempfile::tempdir().unwrap();
    let st = Command::new(BIN)
        .args(["demo", "--cells", "2000", "--nodes", "0", "--out-dir"])
        .arg(dir.path())
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(st.success());
    let scene = dir.path().join("hydrogen.toml");
    let s = Server::start(&[scene.to_str().unwrap(), "--width", "48", "--height", "48"]);
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let (mut ws, _) = tokio_tungstenite::connect_async(s.ws_url()).await.unwrap();
        let (hello, _) = next(&mut ws).await;
        assert_eq!(hello["fields"].as_array().unwrap().len(), 1, "{hello}");
        assert_eq!(hello["steps"].as_array().unwrap().len(), 1, "{hello}");
        let _ = next_frame(&mut ws).await;
        let e = answer(
            &mut ws,
            serde_json::json!({"type": "data", "field": "speed"}),
        )
        .await;
        assert_eq!(e["type"], "error", "{e}");
    });
    s.interrupt();
}

/// Writes a stand-in `ffmpeg` into `bin` that answers `-version`, counts
/// the PNG frames of its input folder into `log` and writes a movie.
#[cfg(unix)]
fn fake_ffmpeg(bin: &std::path::Path, log: &std::path::Path) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::create_dir_all(bin).unwrap();
    let fake = bin.join("ffmpeg");
    std::fs::write(
        &fake,
        format!(
            "#!/bin/sh\n[ \"$1\" = -version ] && exit 0\nfor a in \"$@\"; do last=$a; done\nls $(dirname \"$7\") | grep -c png > {}\necho movie > \"$last\"\n",
            log.display()
        ),
    )
    .unwrap();
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// Records a movie: the full frames shown while recording (the current
/// one and one per view change) go to ffmpeg, the movie is served at
/// `/movie.mp4`; without ffmpeg the page is told so.
#[cfg(unix)]
#[test]
fn a_movie_of_the_full_frames_shown_while_recording() {
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("bin");
    let log = dir.path().join("frames.txt");
    fake_ffmpeg(&bin, &log);
    let real = Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !real {
        eprintln!("a_movie_of_the_full_frames_shown_while_recording: no ffmpeg on PATH: the movie is made by a stand-in ffmpeg only");
    }
    let sys_path = std::env::var("PATH").unwrap_or_default();
    let fake_path = format!("{}:{sys_path}", bin.display());
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let mut runs = vec![
        ("stand-in", fake_path.clone()),
        ("none", empty.display().to_string()),
    ];
    if real {
        runs.push(("ffmpeg", sys_path.clone()));
    }
    for (which, path) in runs {
        let s = Server::start_with_path(
            &[
                "tests/data/aorta-small-view-b.toml",
                "--width",
                "64",
                "--height",
                "48",
            ],
            Some(&path),
        );
        let rt = tokio::runtime::Runtime::new().unwrap();
        rt.block_on(async {
            let (mut ws, _) = tokio_tungstenite::connect_async(s.ws_url()).await.unwrap();
            let _ = next(&mut ws).await;
            let (first, _) = next_frame(&mut ws).await;
            let cam = first["scene"]["camera"].clone();
            let m = answer(
                &mut ws,
                serde_json::json!({"type": "movie", "action": "start"}),
            )
            .await;
            if which == "none" {
                assert_eq!(m["type"], "error", "{m}");
                assert!(
                    m["message"]
                        .as_str()
                        .unwrap()
                        .contains("ffmpeg is not on PATH"),
                    "{m}"
                );
                return;
            }
            assert_eq!(
                (m["type"].as_str(), m["state"].as_str()),
                (Some("movie"), Some("recording")),
                "{m}"
            );
            assert_eq!(m["frames"], 1, "the frame shown now is the first: {m}");
            for k in 1..=2u64 {
                let msg = camera_msg(&cam, 20.0 * k as f64, false, k);
                ws.send(Message::Text(msg.into())).await.unwrap();
                let (f, _) = next_frame(&mut ws).await;
                assert_eq!(f["scale"], 1);
            }
            let m = answer(
                &mut ws,
                serde_json::json!({"type": "movie", "action": "stop"}),
            )
            .await;
            assert_eq!(m["state"], "writing", "{m}");
            let (m, _) = next(&mut ws).await;
            assert_eq!(
                (m["state"].as_str(), m["frames"].as_u64()),
                (Some("ready"), Some(3)),
                "{m}"
            );
            let e = answer(
                &mut ws,
                serde_json::json!({"type": "movie", "action": "stop"}),
            )
            .await;
            assert_eq!(e["type"], "error", "stop without a recording: {e}");
        });
        if which == "none" {
            assert_eq!(s.get(&format!("/movie.mp4?token={}", s.token)).0, 404);
            s.interrupt();
            continue;
        }
        assert_eq!(s.get("/movie.mp4").0, 403, "the movie needs the token");
        let (st, movie) = s.get(&format!("/movie.mp4?token={}", s.token));
        assert_eq!(st, 200);
        assert!(!movie.is_empty());
        if which == "stand-in" {
            assert_eq!(movie, b"movie\n");
            assert_eq!(
                std::fs::read_to_string(&log).unwrap().trim(),
                "3",
                "3 frames to ffmpeg"
            );
        } else {
            assert_eq!(&movie[4..8], b"ftyp", "an MP4");
        }
        s.interrupt();
    }
}
