//! Progress bars on stderr, drawn only where it is a terminal.

use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use raycast::Progress;

/// A progress bar of `len` steps drawn with `template` on stderr, or a hidden one unless
/// `enabled` and stderr is a terminal.
pub fn bar(enabled: bool, len: u64, template: &str) -> ProgressBar {
    if !enabled || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    ProgressBar::new(len)
        .with_style(ProgressStyle::with_template(template).expect("valid template"))
}

/// A bar of views rendered, with their rate and the time left, on stderr where it is a
/// terminal (hidden otherwise); its length is set as the views are counted.
pub fn views_bar() -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let rate = |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
        let _ = write!(w, "{:.1}", state.per_sec());
    };
    let template = "{bar:40} {pos}/{len} views, {rate} views/s, {eta} left";
    let style = ProgressStyle::with_template(template).expect("valid template");
    ProgressBar::new(0).with_style(style.with_key("rate", rate))
}

/// Runs `work`, which may render on the CPU counting its rows in the [`Progress`] it is given;
/// if it is still running after a second and stderr is a terminal, shows a bar of those rows.
pub fn cpu_rows<T: Send>(work: impl FnOnce(Option<Arc<Progress>>) -> T + Send) -> T {
    if !std::io::stderr().is_terminal() {
        return work(None);
    }
    let progress = Arc::new(Progress::default());
    std::thread::scope(|s| {
        let watched = Arc::clone(&progress);
        let worker = s.spawn(|| work(Some(watched)));
        let start = Instant::now();
        let mut shown: Option<ProgressBar> = None;
        while !worker.is_finished() {
            std::thread::sleep(Duration::from_millis(50));
            let rows = progress.rows.load(Ordering::Relaxed) as u64;
            if shown.is_none() && rows > 0 && start.elapsed() > Duration::from_secs(1) {
                let template = "cpu render {bar:40} {pos}/{len} rows, {eta} left";
                shown = Some(bar(true, rows, template));
            }
            if let Some(b) = &shown {
                b.set_length(rows.max(1));
                b.set_position(progress.rows_done.load(Ordering::Relaxed) as u64);
            }
        }
        if let Some(b) = shown {
            b.finish_and_clear();
        }
        worker.join().expect("the renderer does not panic")
    })
}
