//! The command's allocator: the system's, except that an allocation the system refuses ends
//! the command with one line on stderr, its partial files removed, and exit code 2, like every
//! error, instead of Rust's abort (`memory allocation of N bytes failed`, SIGABRT, exit 134).
//! The renders whose memory is known are refused before they start (the library's
//! `Error::Memory`); this catches what is left: a mesh too large to load, the encoded files of
//! an image that only just fit. An allocation that expects to be refused (`try_reserve`) ends
//! the command too.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, Ordering};

/// [`System`], ending the command where it returns no memory (module docs).
pub(crate) struct ExitOnFailure;

/// The exit code: 2, as for every error.
const EXIT: i32 = 2;

/// Whether a thread is on the way out after a refused allocation.
static FAILED: AtomicBool = AtomicBool::new(false);

thread_local! {
    /// Whether this thread is the one on the way out.
    static LEAVING: Cell<bool> = const { Cell::new(false) };
}

// SAFETY: every call is passed on to `System` with the same arguments, and its result
// returned unchanged; a null result does not return at all.
unsafe impl GlobalAlloc for ExitOnFailure {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's guarantees, passed on.
        let p = unsafe { System.alloc(layout) };
        if p.is_null() {
            refused(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's guarantees, passed on.
        let p = unsafe { System.alloc_zeroed(layout) };
        if p.is_null() {
            refused(layout.size());
        }
        p
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller's guarantees, passed on.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            refused(new_size);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's guarantees, passed on.
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Ends the command after the system refused `size` bytes: removes the files being written
/// and prints one line ([`raycast_cli::abandon`], which allocates little), without allocating
/// here.
#[cold]
fn refused(size: usize) -> ! {
    // Refused again on the way out: leave at once.
    if LEAVING.try_with(|l| l.replace(true)).unwrap_or(true) {
        leave(b"error: out of memory\n");
    }
    // Another thread is on the way out; it ends the process.
    if FAILED.swap(true, Ordering::SeqCst) {
        loop {
            std::thread::sleep(std::time::Duration::from_secs(1));
        }
    }
    let mut line = Line::default();
    line.push("error: out of memory: the system refused ");
    line.push_number(size);
    line.push(" bytes; no partial file left");
    // An allocator must not unwind: should printing the line panic (stderr closed), leave.
    let _ = std::panic::catch_unwind(|| raycast_cli::abandon(EXIT, line.as_str()));
    leave(b"error: out of memory\n")
}

/// Writes `message` on stderr and exits, allocating nothing.
fn leave(message: &[u8]) -> ! {
    use std::io::Write;
    let _ = std::io::stderr().write_all(message);
    #[cfg(unix)]
    // SAFETY: `_exit` ends the process at once, running no handler that could allocate.
    unsafe {
        libc::_exit(EXIT)
    }
    #[cfg(not(unix))]
    std::process::exit(EXIT)
}

/// A line of text built on the stack.
struct Line {
    bytes: [u8; 128],
    len: usize,
}

impl Default for Line {
    fn default() -> Line {
        Line {
            bytes: [0; 128],
            len: 0,
        }
    }
}

impl Line {
    /// Appends `text`, as much of it as fits.
    fn push(&mut self, text: &str) {
        let n = text.len().min(self.bytes.len() - self.len);
        self.bytes[self.len..self.len + n].copy_from_slice(&text.as_bytes()[..n]);
        self.len += n;
    }

    /// Appends `n` in decimal.
    fn push_number(&mut self, mut n: usize) {
        let mut digits = [0u8; 20];
        let mut k = digits.len();
        loop {
            k -= 1;
            digits[k] = b'0' + (n % 10) as u8;
            n /= 10;
            if n == 0 {
                break;
            }
        }
        self.push(std::str::from_utf8(&digits[k..]).unwrap_or("?"));
    }

    fn as_str(&self) -> &str {
        std::str::from_utf8(&self.bytes[..self.len]).unwrap_or("error: out of memory")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_built_on_the_stack() {
        let mut line = Line::default();
        line.push("refused ");
        line.push_number(33973862400);
        line.push_number(0);
        assert_eq!(line.as_str(), "refused 339738624000");
        line.push(&"x".repeat(200));
        assert_eq!(line.as_str().len(), 128);
    }
}
