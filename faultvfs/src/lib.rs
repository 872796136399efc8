//! A SQLite VFS shim for crash tests, in the manner of SQLite's own crash testing (its
//! test VFS stops a writer at chosen I/O calls): every call through which a connection
//! changes a file — `xWrite`, `xTruncate`, `xSync` and `xDelete` (the deletion of a
//! rollback journal is the commit point) — is a numbered *write point*. With
//! [`install`]`(n)`, the process exits with [`STOPPED`] on entering write point `n`,
//! before that call reaches the file: points `1 … n − 1` are on disk, the rest never
//! happen, as when a process is killed there. The I/O itself is the platform VFS's
//! (SQLite's `unix`), unchanged.
//!
//! Test-only: errmap forbids unsafe code, and this crate, which needs it to speak SQLite's
//! C interface, is a dev-dependency of its tests and nothing else.

use std::ffi::{c_char, c_int, c_void};
use std::ptr::null_mut;
use std::sync::atomic::{AtomicPtr, AtomicU64, Ordering};

use rusqlite::ffi;

/// The exit status of a process stopped at its write point.
pub const STOPPED: i32 = 86;

static POINTS: AtomicU64 = AtomicU64::new(0);
static STOP_AT: AtomicU64 = AtomicU64::new(u64::MAX);
static REAL: AtomicPtr<ffi::sqlite3_vfs> = AtomicPtr::new(null_mut());

/// Registers the shim as SQLite's default VFS (once per process; later calls only change
/// `stop_at`). `stop_at` = 0 never stops: the shim only counts.
pub fn install(stop_at: u64) {
    STOP_AT.store(
        if stop_at == 0 { u64::MAX } else { stop_at },
        Ordering::SeqCst,
    );
    if !REAL.load(Ordering::SeqCst).is_null() {
        return;
    }
    // SAFETY: sqlite3_vfs_find initialises SQLite and returns its default VFS, which lives
    // as long as the process; the shim's VFS is leaked, so it does too.
    unsafe {
        let real = ffi::sqlite3_vfs_find(std::ptr::null());
        assert!(!real.is_null(), "SQLite has no default VFS");
        REAL.store(real, Ordering::SeqCst);
        let vfs = Box::leak(Box::new(ffi::sqlite3_vfs {
            iVersion: 2,
            szOsFile: std::mem::size_of::<ShimFile>() as c_int + (*real).szOsFile,
            mxPathname: (*real).mxPathname,
            pNext: null_mut(),
            zName: c"errmap-faultvfs".as_ptr(),
            pAppData: null_mut(),
            xOpen: Some(x_open),
            xDelete: Some(x_delete),
            xAccess: Some(x_access),
            xFullPathname: Some(x_full_pathname),
            xDlOpen: None,
            xDlError: None,
            xDlSym: None,
            xDlClose: None,
            xRandomness: Some(x_randomness),
            xSleep: Some(x_sleep),
            xCurrentTime: Some(x_current_time),
            xGetLastError: Some(x_get_last_error),
            xCurrentTimeInt64: Some(x_current_time_int64),
            xSetSystemCall: None,
            xGetSystemCall: None,
            xNextSystemCall: None,
        }));
        let rc = ffi::sqlite3_vfs_register(vfs, 1);
        assert_eq!(rc, ffi::SQLITE_OK, "sqlite3_vfs_register");
    }
}

/// Write points entered so far.
pub fn points() -> u64 {
    POINTS.load(Ordering::SeqCst)
}

fn write_point() {
    let n = POINTS.fetch_add(1, Ordering::SeqCst) + 1;
    if n >= STOP_AT.load(Ordering::SeqCst) {
        // No destructor, no rollback, no flush of SQLite's: the files stay as they are.
        std::process::exit(STOPPED);
    }
}

fn real() -> *mut ffi::sqlite3_vfs {
    REAL.load(Ordering::SeqCst)
}

/// The shim's file: SQLite's header, then the platform file it wraps (in the same
/// allocation, `szOsFile` bytes being asked for both).
#[repr(C)]
struct ShimFile {
    base: ffi::sqlite3_file,
    real: *mut ffi::sqlite3_file,
}

/// The wrapped file and its methods.
///
/// # Safety
/// `f` is a file the shim opened.
unsafe fn inner(
    f: *mut ffi::sqlite3_file,
) -> (*mut ffi::sqlite3_file, &'static ffi::sqlite3_io_methods) {
    // SAFETY: x_open set `real` and its methods before SQLite saw the file.
    unsafe {
        let real = (*(f as *mut ShimFile)).real;
        (real, &*(*real).pMethods)
    }
}

static METHODS: ffi::sqlite3_io_methods = ffi::sqlite3_io_methods {
    iVersion: 1,
    xClose: Some(x_close),
    xRead: Some(x_read),
    xWrite: Some(x_write),
    xTruncate: Some(x_truncate),
    xSync: Some(x_sync),
    xFileSize: Some(x_file_size),
    xLock: Some(x_lock),
    xUnlock: Some(x_unlock),
    xCheckReservedLock: Some(x_check_reserved_lock),
    xFileControl: Some(x_file_control),
    xSectorSize: Some(x_sector_size),
    xDeviceCharacteristics: Some(x_device_characteristics),
    xShmMap: None,
    xShmLock: None,
    xShmBarrier: None,
    xShmUnmap: None,
    xFetch: None,
    xUnfetch: None,
};

macro_rules! forward {
    ($name:ident, $field:ident, ($($arg:ident: $ty:ty),*)) => {
        unsafe extern "C" fn $name(f: *mut ffi::sqlite3_file $(, $arg: $ty)*) -> c_int {
            // SAFETY: SQLite calls the shim's methods on the shim's files only.
            unsafe {
                let (real, m) = inner(f);
                match m.$field {
                    Some(x) => x(real $(, $arg)*),
                    None => ffi::SQLITE_IOERR,
                }
            }
        }
    };
}

forward!(x_close, xClose, ());
forward!(x_read, xRead, (buf: *mut c_void, amt: c_int, off: ffi::sqlite3_int64));
forward!(x_write_real, xWrite, (buf: *const c_void, amt: c_int, off: ffi::sqlite3_int64));
forward!(x_truncate_real, xTruncate, (size: ffi::sqlite3_int64));
forward!(x_sync_real, xSync, (flags: c_int));
forward!(x_file_size, xFileSize, (size: *mut ffi::sqlite3_int64));
forward!(x_lock, xLock, (level: c_int));
forward!(x_unlock, xUnlock, (level: c_int));
forward!(x_check_reserved_lock, xCheckReservedLock, (out: *mut c_int));
forward!(x_file_control, xFileControl, (op: c_int, arg: *mut c_void));
forward!(x_sector_size, xSectorSize, ());
forward!(x_device_characteristics, xDeviceCharacteristics, ());

unsafe extern "C" fn x_write(
    f: *mut ffi::sqlite3_file,
    buf: *const c_void,
    amt: c_int,
    off: ffi::sqlite3_int64,
) -> c_int {
    write_point();
    // SAFETY: the arguments are SQLite's, passed on unchanged.
    unsafe { x_write_real(f, buf, amt, off) }
}

unsafe extern "C" fn x_truncate(f: *mut ffi::sqlite3_file, size: ffi::sqlite3_int64) -> c_int {
    write_point();
    // SAFETY: as x_write.
    unsafe { x_truncate_real(f, size) }
}

unsafe extern "C" fn x_sync(f: *mut ffi::sqlite3_file, flags: c_int) -> c_int {
    write_point();
    // SAFETY: as x_write.
    unsafe { x_sync_real(f, flags) }
}

unsafe extern "C" fn x_open(
    _vfs: *mut ffi::sqlite3_vfs,
    name: ffi::sqlite3_filename,
    f: *mut ffi::sqlite3_file,
    flags: c_int,
    out_flags: *mut c_int,
) -> c_int {
    // SAFETY: SQLite gave `szOsFile` bytes at `f`: the shim's header, then the platform
    // file, which the platform VFS opens in place.
    unsafe {
        let shim = f as *mut ShimFile;
        let real_file =
            (f as *mut u8).add(std::mem::size_of::<ShimFile>()) as *mut ffi::sqlite3_file;
        (*shim).real = real_file;
        (*shim).base.pMethods = std::ptr::null();
        let vfs = real();
        let rc = match (*vfs).xOpen {
            Some(x) => x(vfs, name, real_file, flags, out_flags),
            None => ffi::SQLITE_CANTOPEN,
        };
        if !(*real_file).pMethods.is_null() {
            (*shim).base.pMethods = &METHODS;
        }
        rc
    }
}

unsafe extern "C" fn x_delete(
    _vfs: *mut ffi::sqlite3_vfs,
    name: *const c_char,
    sync_dir: c_int,
) -> c_int {
    write_point();
    // SAFETY: the platform VFS with SQLite's arguments.
    unsafe {
        let vfs = real();
        (*vfs)
            .xDelete
            .map_or(ffi::SQLITE_IOERR, |x| x(vfs, name, sync_dir))
    }
}

unsafe extern "C" fn x_access(
    _vfs: *mut ffi::sqlite3_vfs,
    name: *const c_char,
    flags: c_int,
    out: *mut c_int,
) -> c_int {
    // SAFETY: as x_delete.
    unsafe {
        let vfs = real();
        (*vfs)
            .xAccess
            .map_or(ffi::SQLITE_IOERR, |x| x(vfs, name, flags, out))
    }
}

unsafe extern "C" fn x_full_pathname(
    _vfs: *mut ffi::sqlite3_vfs,
    name: *const c_char,
    n: c_int,
    out: *mut c_char,
) -> c_int {
    // SAFETY: as x_delete.
    unsafe {
        let vfs = real();
        (*vfs)
            .xFullPathname
            .map_or(ffi::SQLITE_IOERR, |x| x(vfs, name, n, out))
    }
}

unsafe extern "C" fn x_randomness(
    _vfs: *mut ffi::sqlite3_vfs,
    n: c_int,
    out: *mut c_char,
) -> c_int {
    // SAFETY: as x_delete.
    unsafe {
        let vfs = real();
        (*vfs).xRandomness.map_or(0, |x| x(vfs, n, out))
    }
}

unsafe extern "C" fn x_sleep(_vfs: *mut ffi::sqlite3_vfs, us: c_int) -> c_int {
    // SAFETY: as x_delete.
    unsafe {
        let vfs = real();
        (*vfs).xSleep.map_or(0, |x| x(vfs, us))
    }
}

unsafe extern "C" fn x_current_time(_vfs: *mut ffi::sqlite3_vfs, out: *mut f64) -> c_int {
    // SAFETY: as x_delete.
    unsafe {
        let vfs = real();
        (*vfs)
            .xCurrentTime
            .map_or(ffi::SQLITE_ERROR, |x| x(vfs, out))
    }
}

unsafe extern "C" fn x_get_last_error(
    _vfs: *mut ffi::sqlite3_vfs,
    n: c_int,
    out: *mut c_char,
) -> c_int {
    // SAFETY: as x_delete.
    unsafe {
        let vfs = real();
        (*vfs).xGetLastError.map_or(0, |x| x(vfs, n, out))
    }
}

unsafe extern "C" fn x_current_time_int64(
    _vfs: *mut ffi::sqlite3_vfs,
    out: *mut ffi::sqlite3_int64,
) -> c_int {
    // SAFETY: as x_delete.
    unsafe {
        let vfs = real();
        (*vfs)
            .xCurrentTimeInt64
            .map_or(ffi::SQLITE_ERROR, |x| x(vfs, out))
    }
}
