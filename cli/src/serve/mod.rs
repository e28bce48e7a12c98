//! `raycast serve`: a local web page showing a scene's render, rendered again whenever the
//! scene, a mesh or the shade hook is saved, with the camera moved by the mouse (docs/serve.md).
//!
//! One thread watches the files and reloads them (`state.rs`); the HTTP server hands each
//! request to a thread of its own (`http.rs`); frames render one at a time, on the thread that
//! asked, through the scene's [`raycast::Viewer`] (`frame.rs`).

mod frame;
mod http;
mod state;

use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use raycast::{Error, Gpu, Precision, Result};

/// What `raycast serve` is asked to show, and where.
#[derive(Clone, Debug)]
pub struct Options {
    /// A scene file or a mesh file; `None`: the built-in default scene.
    pub scene: Option<PathBuf>,
    /// The shade hook colouring the colour tab.
    pub shader: Option<PathBuf>,
    /// The course's ray tracer colours the colour tab.
    pub lit: bool,
    /// The full image size, instead of the scene's resolution.
    pub size: Option<[u32; 2]>,
    /// The GPU's arithmetic.
    pub precision: Precision,
    /// The address to listen on.
    pub bind: IpAddr,
    /// The port (0: any free one).
    pub port: u16,
}

/// The running server, for [`stop`].
static SERVER: OnceLock<Arc<tiny_http::Server>> = OnceLock::new();

/// Stops a running server (its request loop ends, [`run`] returns); `false` when none runs.
/// Called from the interrupt handler.
pub fn stop() -> bool {
    match SERVER.get() {
        Some(server) => {
            server.unblock();
            true
        }
        None => false,
    }
}

/// Loads the files, renders the first frame (so that what cannot render is refused before the
/// page opens), listens, and calls `ready` with the page's address; then serves until [`stop`].
pub fn run(options: &Options, ready: impl FnOnce(&str)) -> Result<()> {
    let gpu = Gpu::new()?;
    let shared = Arc::new(state::Shared::load(options.clone(), gpu)?);
    frame::warm_up(&shared)?;
    let address = SocketAddr::new(options.bind, options.port);
    let server = tiny_http::Server::http(address).map_err(|e| Error::Argument {
        option: "--port".into(),
        message: format!("cannot listen on {address}: {e}"),
    })?;
    let server = Arc::new(server);
    let local = server
        .server_addr()
        .to_ip()
        .ok_or_else(|| Error::Device("the server has no IP address".into()))?;
    let _ = SERVER.set(Arc::clone(&server));
    state::watch(Arc::clone(&shared));
    ready(&format!("http://{}/", http::host_of(local)));
    let origin = http::Origin::new(local);
    for request in server.incoming_requests() {
        let (shared, origin) = (Arc::clone(&shared), origin.clone());
        std::thread::spawn(move || http::handle(request, &shared, &origin));
    }
    // Stopped: the frame being rendered, if any, ends before the process does.
    drop(shared.current.lock());
    Ok(())
}
