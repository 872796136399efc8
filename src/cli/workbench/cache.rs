//! Results computed once. Each job's result is kept with the identity of the files it was
//! computed from (path, modification time, size and, on Unix, device and inode) and
//! served again while they are unchanged; a file changed, replaced or removed makes the
//! next request compute it again. A request for a result being computed waits for it
//! instead of computing it a second time (the start-up warm-up and a reader share it).
//!
//! A page does not wait: on the thread of [`without_waiting`], a result being made by
//! another request (the warm-up, most often) answers at once [`DocError::Pending`], and
//! the page says so and fills in by itself (`pages`). The documents wait.
//!
//! Errors are kept like results: a file that cannot be read gives the same message until
//! it changes. Each store holds at most [`MAX_ENTRIES`] results; past that the one used
//! longest ago is dropped.

use std::cell::Cell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, TryLockError};
use std::time::SystemTime;

use super::docs::DocError;

/// The most results one store keeps.
pub(crate) const MAX_ENTRIES: usize = 256;

/// What one input file was when a result was computed from it.
#[derive(Debug, Clone, PartialEq, Eq)]
struct FileStamp {
    path: PathBuf,
    /// `None`: the file was not there (its absence is part of the result too).
    seen: Option<(Option<SystemTime>, u64, u64, u64)>,
}

impl FileStamp {
    fn of(path: &Path) -> FileStamp {
        let seen = std::fs::metadata(path).ok().map(|m| {
            let (dev, ino) = identity(&m);
            (m.modified().ok(), m.len(), dev, ino)
        });
        FileStamp {
            path: path.to_path_buf(),
            seen,
        }
    }
}

#[cfg(unix)]
fn identity(m: &std::fs::Metadata) -> (u64, u64) {
    use std::os::unix::fs::MetadataExt;
    (m.dev(), m.ino())
}

#[cfg(not(unix))]
fn identity(_: &std::fs::Metadata) -> (u64, u64) {
    (0, 0)
}

thread_local! {
    /// Whether this thread answers a result being made elsewhere as pending.
    static NO_WAIT: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f` with every result being made by another thread answered at once as
/// [`DocError::Pending`] instead of waited for (a kept result, or one nobody is making,
/// is served or made as always).
pub(crate) fn without_waiting<R>(f: impl FnOnce() -> R) -> R {
    struct Reset(bool);
    impl Drop for Reset {
        fn drop(&mut self) {
            NO_WAIT.with(|w| w.set(self.0));
        }
    }
    let _reset = Reset(NO_WAIT.with(|w| w.replace(true)));
    f()
}

type Kept<T> = Option<(Vec<FileStamp>, Result<Arc<T>, DocError>)>;

struct Slot<T> {
    kept: Mutex<Kept<T>>,
    used: AtomicU64,
}

/// One job's results by key (the item and the job's options).
pub(crate) struct Memo<T> {
    slots: Mutex<HashMap<String, Arc<Slot<T>>>>,
    clock: AtomicU64,
}

impl<T> Default for Memo<T> {
    fn default() -> Self {
        Memo {
            slots: Mutex::new(HashMap::new()),
            clock: AtomicU64::new(0),
        }
    }
}

impl<T> std::fmt::Debug for Memo<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.slots.lock().map_or(0, |s| s.len());
        write!(f, "Memo({n} results)")
    }
}

impl<T> Memo<T> {
    /// The result for `key`, computed from the files `inputs` by `compute` unless a result
    /// computed from the same files is kept.
    pub(crate) fn get(
        &self,
        key: &str,
        inputs: &[&Path],
        compute: impl FnOnce() -> Result<T, DocError>,
    ) -> Result<Arc<T>, DocError> {
        let slot = self.slot(key)?;
        let poisoned = || DocError::Internal("a result store was poisoned".into());
        let mut kept = match slot.kept.try_lock() {
            Ok(k) => k,
            Err(TryLockError::WouldBlock) if NO_WAIT.with(Cell::get) => {
                return Err(DocError::Pending);
            }
            Err(TryLockError::WouldBlock) => slot.kept.lock().map_err(|_| poisoned())?,
            Err(TryLockError::Poisoned(_)) => return Err(poisoned()),
        };
        // The stamps are taken before computing: a file changed while it is read makes
        // the next request compute again.
        let stamps: Vec<FileStamp> = inputs.iter().map(|p| FileStamp::of(p)).collect();
        if let Some((s, r)) = kept.as_ref()
            && *s == stamps
        {
            return r.clone();
        }
        let r = compute().map(Arc::new);
        *kept = Some((stamps, r.clone()));
        r
    }

    fn slot(&self, key: &str) -> Result<Arc<Slot<T>>, DocError> {
        let mut slots = self
            .slots
            .lock()
            .map_err(|_| DocError::Internal("a result store was poisoned".into()))?;
        let now = self.clock.fetch_add(1, Ordering::Relaxed);
        if let Some(s) = slots.get(key) {
            s.used.store(now, Ordering::Relaxed);
            return Ok(Arc::clone(s));
        }
        if slots.len() >= MAX_ENTRIES {
            let oldest = slots
                .iter()
                .min_by_key(|(_, s)| s.used.load(Ordering::Relaxed))
                .map(|(k, _)| k.clone());
            if let Some(k) = oldest {
                slots.remove(&k);
            }
        }
        let s = Arc::new(Slot {
            kept: Mutex::new(None),
            used: AtomicU64::new(now),
        });
        slots.insert(key.to_string(), Arc::clone(&s));
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_result_is_made_once_per_state_of_its_files() {
        let dir = tempfile::tempdir().expect("tempdir");
        let a = dir.path().join("a.csv");
        let b = dir.path().join("b.csv");
        std::fs::write(&a, "1").expect("write");
        let memo: Memo<String> = Memo::default();
        let runs = Cell::new(0);
        let get = || {
            memo.get("k", &[&a, &b], || {
                runs.set(runs.get() + 1);
                Ok(std::fs::read_to_string(&a).unwrap_or_default())
            })
        };
        assert_eq!(get().map(|v| v.to_string()), Ok("1".into()));
        assert_eq!(get().map(|v| v.to_string()), Ok("1".into()));
        assert_eq!(runs.get(), 1, "the same files: kept");
        // A file replaced by a rename (another inode, same size) is a new file.
        let tmp = dir.path().join("a.new");
        std::fs::write(&tmp, "2").expect("write");
        std::fs::rename(&tmp, &a).expect("rename");
        assert_eq!(get().map(|v| v.to_string()), Ok("2".into()));
        assert_eq!(runs.get(), 2);
        // A file that appears beside it (absent before) counts too.
        std::fs::write(&b, "x").expect("write");
        let _ = get();
        assert_eq!(runs.get(), 3);
        let _ = get();
        assert_eq!(runs.get(), 3);
    }

    #[test]
    fn a_page_does_not_wait_for_a_result_being_made_and_a_document_does() {
        let memo: Arc<Memo<u32>> = Arc::default();
        let (started_tx, started) = std::sync::mpsc::channel();
        let (release, release_rx) = std::sync::mpsc::channel::<()>();
        let maker = {
            let memo = Arc::clone(&memo);
            std::thread::spawn(move || {
                memo.get("k", &[], || {
                    started_tx.send(()).expect("started");
                    release_rx.recv().expect("released");
                    Ok(7)
                })
            })
        };
        started.recv().expect("the maker holds the slot");
        let runs = Cell::new(0);
        let second = || {
            runs.set(runs.get() + 1);
            Ok(8)
        };
        // A page: at once, pending; nothing made a second time.
        assert_eq!(
            without_waiting(|| memo.get("k", &[], second)),
            Err(DocError::Pending)
        );
        assert_eq!(runs.get(), 0);
        // Another key nobody is making is made as always, even for a page.
        assert_eq!(
            without_waiting(|| memo.get("other", &[], || Ok(1))),
            Ok(Arc::new(1))
        );
        // A document waits, and gets the maker's result.
        let waiter = {
            let memo = Arc::clone(&memo);
            std::thread::spawn(move || memo.get("k", &[], || Ok(9)))
        };
        std::thread::sleep(std::time::Duration::from_millis(50));
        release.send(()).expect("release");
        assert_eq!(maker.join().expect("maker"), Ok(Arc::new(7)));
        assert_eq!(waiter.join().expect("waiter"), Ok(Arc::new(7)));
        // Once made, a page gets it too; the flag ends with the call.
        assert_eq!(
            without_waiting(|| memo.get("k", &[], second)),
            Ok(Arc::new(7))
        );
        assert!(!NO_WAIT.with(Cell::get));
    }

    #[test]
    fn a_refusal_is_kept_and_the_store_is_bounded() {
        let memo: Memo<u32> = Memo::default();
        let runs = Cell::new(0);
        let refuse = || {
            runs.set(runs.get() + 1);
            Err(DocError::Bad("no".into()))
        };
        assert_eq!(memo.get("k", &[], refuse), Err(DocError::Bad("no".into())));
        assert_eq!(
            memo.get("k", &[], || Ok(1)),
            Err(DocError::Bad("no".into()))
        );
        assert_eq!(runs.get(), 1);
        for k in 0..MAX_ENTRIES + 10 {
            let _ = memo.get(&k.to_string(), &[], || Ok(1));
        }
        let held = memo.slots.lock().map(|s| s.len()).unwrap_or(0);
        assert_eq!(held, MAX_ENTRIES);
        // The newest are kept, the oldest dropped.
        assert!(memo.slots.lock().is_ok_and(|s| {
            s.contains_key(&(MAX_ENTRIES + 9).to_string()) && !s.contains_key("k")
        }));
    }
}
