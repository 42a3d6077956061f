//! The worker thread every whole-record function runs on: the estimators
//! hold their windows inline and are built on the stack before boxing, so
//! they need a larger stack than a caller's thread has. The CLI runs every
//! command on it, the Python face every fit (without the GIL). [`boxed`]
//! builds each of them in a frame of its own, so they share one stretch
//! of that stack.

use crate::error::{Error, ErrorKind};

/// Stack of the worker thread (bytes).
pub const WORKER_STACK: usize = 512 << 20;

/// Runs `f` on a worker thread with [`WORKER_STACK`] bytes of stack and
/// returns what it returns. A panic comes back as an
/// [`ErrorKind::Internal`] error.
///
/// ```
/// let n = fracbms_host::worker::on_worker(|| Ok::<_, fracbms_host::Error>(2 + 2))?;
/// assert_eq!(n, 4);
/// # Ok::<(), fracbms_host::Error>(())
/// ```
pub fn on_worker<R: Send, E: Send + From<Error>>(
    f: impl FnOnce() -> std::result::Result<R, E> + Send,
) -> std::result::Result<R, E> {
    std::thread::scope(|scope| {
        match std::thread::Builder::new()
            .stack_size(WORKER_STACK)
            .spawn_scoped(scope, f)
        {
            Ok(h) => h.join().unwrap_or_else(|_| {
                Err(Error::new(ErrorKind::Internal, "internal error (please report it)").into())
            }),
            Err(e) => Err(Error::new(
                ErrorKind::Internal,
                format!("cannot start the worker thread: {e}"),
            )
            .into()),
        }
    })
}

/// Builds a large value (an estimator holding its window inline) with
/// `make` and moves it to the heap, in a frame of its own.
///
/// A frame is probed page by page when it is entered, so a function
/// holding such a value inline touches every page of it, whichever branch
/// it takes. Built here, every estimator of a fit is built in one stretch
/// of the stack, this function's frame: on a 48 800-row record 20 MB (a
/// 10 MB refinement and its result), where two nested frames holding it
/// inline would touch 39 MB (docs/performance.md). The heap block it
/// moves to is first marked for huge pages ([`huge_pages`]).
///
/// ```
/// let v = fracbms_host::worker::boxed(|| Ok::<_, ()>([1.0f64; 4]))?;
/// assert_eq!(v[3], 1.0);
/// # Ok::<(), ()>(())
/// ```
#[inline(never)]
pub fn boxed<T, E>(
    make: impl FnOnce() -> std::result::Result<T, E>,
) -> std::result::Result<Box<T>, E> {
    let mut block = Box::<T>::new_uninit();
    huge_pages(block.as_mut_ptr().cast(), std::mem::size_of::<T>());
    Ok(Box::write(block, make()?))
}

/// From this many bytes a heap block is marked for huge pages
/// ([`huge_pages`]): a few of them.
pub const HUGE_PAGE_BYTES: usize = 8 << 20;

/// Asks the kernel to back the pages of `len` bytes from `start` (a block
/// this process allocated and has not yet written) with transparent huge
/// pages, when the block is at least [`HUGE_PAGE_BYTES`] and the system
/// allows them on request (Linux with `transparent_hugepage` at
/// `madvise` or `always`): its first writes then take one page fault per
/// 2 MiB instead of one per 4 KiB, each clearing a huge page. A hint only:
/// elsewhere, or when refused, nothing changes. On the made 200 000-row
/// record a fit's three 40 MB refinements are the larger part of its
/// page faults (docs/performance.md).
pub fn huge_pages(start: *mut u8, len: usize) {
    #[cfg(target_os = "linux")]
    if len >= HUGE_PAGE_BYTES {
        // The whole pages inside the block.
        let page = 4096;
        let from = (start as usize).next_multiple_of(page);
        let to = (start as usize + len) / page * page;
        if to > from {
            // SAFETY: `madvise` reads no memory and writes none; on this
            // process's own pages `MADV_HUGEPAGE` changes how they are
            // backed, not their contents or their mapping's permissions.
            // Its result is a hint's and is not needed.
            unsafe {
                libc::madvise(from as *mut libc::c_void, to - from, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (start, len);
}
