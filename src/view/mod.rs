//! `pvrsim view`: the live viewer. A small HTTP + WebSocket server (axum on
//! tokio) serves a page embedded in the binary ([`assets`]); the page turns
//! the camera and edits the transfer function, the server renders the
//! newest request ([`render_loop`]: at most one frame in flight, nothing
//! while idle, a reduced resolution while the user drags, the full frame
//! ~150 ms after the last input) and sends each frame as a binary
//! WebSocket message ([`encode`]: JPEG while moving, the PNG `pvrsim
//! render` writes when still). Frames come from a [`backend`]: in this
//! process exactly as `pvrsim render` draws them, or on a cluster.
//!
//! A frontend beside the command line: it calls the job layer
//! ([`crate::job::LoadedRender`], [`crate::job::ClusterJob`]) and shares its
//! writers (the PNG of [`crate::image::Image::png_bytes`], the scene TOML
//! of [`crate::scene::Scene::to_toml`]).

pub mod assets;
pub mod backend;
pub mod cluster;
pub mod encode;
pub mod messages;
pub mod movie;
pub mod pace;
pub mod render_loop;
pub mod server;
pub mod shared;

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;

use clap::{Args, ValueEnum};

use crate::job::args::transport::TransportKind;
use crate::job::render::RenderArgs;

/// The resolution divisor of frames drawn while the user interacts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum InteractiveScale {
    /// Chosen per frame to hold a frame-time target ([`pace`]): the
    /// data at 1/2 or 1/4, or a coarse stand-in of a large mesh at 1/2,
    /// 1/4 or 1/8 (the finest that holds it, from measured frame times).
    Auto,
    /// Full resolution while moving (JPEG still).
    #[value(name = "1")]
    One,
    /// Half resolution along each axis.
    #[value(name = "2")]
    Two,
    /// A quarter along each axis.
    #[value(name = "4")]
    Four,
}

impl InteractiveScale {
    /// The divisor of a fixed scale (`auto`: 2, its finest; [`pace`]
    /// chooses per frame).
    pub fn divisor(self) -> u32 {
        match self {
            InteractiveScale::One => 1,
            InteractiveScale::Two | InteractiveScale::Auto => 2,
            InteractiveScale::Four => 4,
        }
    }
}

/// Options of `pvrsim view`: the scene and `pvrsim render`'s options, the
/// server's, and optionally a cluster.
#[derive(Debug, Clone, Args)]
pub struct ViewArgs {
    /// The render options (as `pvrsim render`'s; `-o`, `--stats`,
    /// `--compare` and `--oracle` do not apply: the page saves screenshots
    /// and scenes).
    #[command(flatten)]
    pub render: RenderArgs,
    /// TCP port; 0 picks a free one.
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Address to listen on (loopback by default; another interface only
    /// when given, always with the token).
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: IpAddr,
    /// Launch the system browser (`xdg-open`) on the page.
    #[arg(long)]
    pub open: bool,
    /// Resolution divisor while the user drags: `auto` (1/2 to 1/8, and a
    /// coarse stand-in of a large mesh, to hold ~40 ms a frame), 1, 2 or 4.
    #[arg(long, value_enum, default_value_t = InteractiveScale::Auto)]
    pub interactive_scale: InteractiveScale,
    /// Mesh scenes: the time steps of a series file (`pvrsim cluster
    /// --series`'s format): the scene's mesh, then each other mesh its
    /// frames name (`mesh = ...`, same topology), in order; the page's
    /// time-step slider picks one (its cameras and transfer functions
    /// are not replayed: `pvrsim cluster --series` does that).
    #[arg(long, value_name = "FILE.toml")]
    pub series: Option<std::path::PathBuf>,
    /// Render on a cluster of N nodes (`pvrsim cluster`'s frames) instead
    /// of in this process.
    #[arg(long, value_name = "N")]
    pub nodes: Option<usize>,
    /// The cluster's transport (with --nodes): threads (default),
    /// processes or tcp.
    #[arg(long, value_enum, requires = "nodes")]
    pub transport: Option<TransportKind>,
    /// The program (and its leading arguments) that starts worker
    /// processes (the Python module sets its interpreter with `-m
    /// pvrsim`). Not a command-line option.
    #[arg(skip)]
    pub worker_argv: Option<Vec<std::ffi::OsString>>,
}

impl ViewArgs {
    /// Refuses the render options that write files (the page does that).
    pub fn check(&self) -> anyhow::Result<()> {
        let r = &self.render;
        anyhow::ensure!(
            r.output == std::path::Path::new("out.png") && r.stats.is_none(),
            "-o and --stats do not apply to `pvrsim view`: the page saves screenshots (PNG) and \
             the current view as a scene TOML; GET /frame.png and /scene.toml serve them"
        );
        anyhow::ensure!(
            !r.compare && !r.oracle,
            "--compare and --oracle do not apply to `pvrsim view` (run `pvrsim render` on the \
             saved scene)"
        );
        if let Some(n) = self.nodes {
            anyhow::ensure!(n >= 1, "--nodes must be at least 1, got {n}");
            anyhow::ensure!(
                !matches!(self.transport, Some(TransportKind::Mpi)),
                "--transport mpi is not served by `pvrsim view` yet: use threads, processes or tcp"
            );
        }
        Ok(())
    }
}

/// A running viewer: its address and token; dropping it does not stop it
/// ([`Viewer::close`] does).
pub struct Viewer {
    /// `http://ADDR:PORT/?token=TOKEN`.
    pub url: String,
    /// The bound address.
    pub addr: SocketAddr,
    /// The access token.
    pub token: String,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<anyhow::Result<()>>>,
}

impl Viewer {
    /// Loads the scene (in this process or on the cluster), binds the
    /// server and starts serving on a thread of its own; returns once the
    /// first frame can be asked for.
    pub fn start(args: &ViewArgs) -> anyhow::Result<Viewer> {
        args.check()?;
        let backend = open_backend(args)?;
        let token = fresh_token()?;
        let listener = std::net::TcpListener::bind((args.bind, args.port))
            .map_err(|e| anyhow::anyhow!("--bind {} --port {}: {e}", args.bind, args.port))?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let host = match addr.ip() {
            IpAddr::V6(ip) => format!("[{ip}]"),
            IpAddr::V4(ip) => ip.to_string(),
        };
        let url = format!("http://{host}:{}/?token={token}", addr.port());
        let shared = Arc::new(shared::Shared::new(
            token.clone(),
            addr.port(),
            backend.info(),
        ));
        let loop_handle = render_loop::spawn(backend, shared.clone(), args.interactive_scale);
        let (stop, stopped) = tokio::sync::oneshot::channel();
        let thread = std::thread::Builder::new()
            .name("pvrsim-view".into())
            .spawn(move || -> anyhow::Result<()> {
                let rt = tokio::runtime::Builder::new_multi_thread()
                    .worker_threads(2)
                    .enable_all()
                    .build()?;
                let served = rt.block_on(server::serve(listener, shared.clone(), stopped));
                shared.shut_down();
                let closed = loop_handle
                    .join()
                    .map_err(|_| anyhow::anyhow!("the render loop panicked"))?;
                served.and(closed)
            })?;
        Ok(Viewer {
            url,
            addr,
            token,
            stop: Some(stop),
            thread: Some(thread),
        })
    }

    /// Stops serving, ends the render loop and the session.
    pub fn close(mut self) -> anyhow::Result<()> {
        self.stop_now()
    }

    fn stop_now(&mut self) -> anyhow::Result<()> {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        match self.thread.take() {
            Some(t) => t
                .join()
                .map_err(|_| anyhow::anyhow!("the viewer's server thread panicked"))?,
            None => Ok(()),
        }
    }

    /// Waits until the server ends (Ctrl-C).
    pub fn wait(mut self) -> anyhow::Result<()> {
        match self.thread.take() {
            Some(t) => t
                .join()
                .map_err(|_| anyhow::anyhow!("the viewer's server thread panicked"))?,
            None => Ok(()),
        }
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        if self.stop.is_some() {
            let _ = self.stop_now();
        }
    }
}

/// The backend `args` asks for, with the scene and data loaded: in this
/// process ([`backend::Local`]) or on a cluster ([`cluster::Cluster`]).
fn open_backend(args: &ViewArgs) -> anyhow::Result<Box<dyn backend::Backend>> {
    let coarse = args.interactive_scale == InteractiveScale::Auto;
    Ok(match args.nodes {
        None => Box::new(backend::Local::open(
            &args.render,
            args.series.as_deref(),
            coarse,
        )?),
        Some(n) => Box::new(cluster::Cluster::open(args, n)?),
    })
}

/// A fresh random token: 16 bytes from the OS, hex.
fn fresh_token() -> anyhow::Result<String> {
    let mut b = [0u8; 16];
    getrandom::fill(&mut b).map_err(|e| anyhow::anyhow!("no random token: {e}"))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// Runs `pvrsim view`: starts the viewer, prints
/// `view: http://127.0.0.1:PORT/?token=TOKEN`, serves until Ctrl-C.
pub fn run(args: ViewArgs) -> anyhow::Result<()> {
    let viewer = Viewer::start(&args)?;
    println!("view: {}", viewer.url);
    if args.open {
        if let Err(e) = std::process::Command::new("xdg-open")
            .arg(&viewer.url)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
        {
            crate::job::output::warn(format!(
                "--open: cannot launch the system browser (xdg-open: {e}); open the URL above"
            ));
        }
    }
    use std::io::Write;
    let _ = std::io::stdout().flush();
    viewer.wait()?;
    eprintln!("view: stopped");
    Ok(())
}
