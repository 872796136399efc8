//! Serving a simulated stream on a pseudo-terminal, paced like the real line.
//!
//! A pty ignores the baud rate, so the pacing is ours: each frame is written when the
//! simulated board would have finished sending it ([`Emitted::line_time_us`]), divided by
//! a speed factor (1 = real time). Writes go in chunks of at most 4 KiB: one large write
//! into a full pty buffer would block past any timeout.

use std::io::{self, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::sim::Emitted;

/// Writes `frames` to `out` at their line times divided by `speed`. Returns the bytes
/// written; stops early (Ok) when `stop` is set. When no byte can be written for `stall`
/// (the host stopped reading, or never opened the port), gives up with
/// [`io::ErrorKind::TimedOut`]; `None` waits for ever.
pub fn serve_paced<W: Write + ?Sized>(
    frames: &[Emitted],
    out: &mut W,
    speed: f64,
    stop: &AtomicBool,
    stall: Option<Duration>,
) -> io::Result<u64> {
    let start = Instant::now();
    let speed = if speed.is_finite() && speed > 0.0 {
        speed
    } else {
        1.0
    };
    let mut written = 0u64;
    let mut pending: Vec<u8> = Vec::with_capacity(4096);
    let mut i = 0;
    while i < frames.len() {
        if stop.load(Ordering::Relaxed) {
            break;
        }
        let due = Duration::from_secs_f64(frames[i].line_time_us as f64 * 1e-6 / speed);
        let now = start.elapsed();
        if due > now {
            std::thread::sleep((due - now).min(Duration::from_millis(50)));
            continue;
        }
        // Everything due by now goes out together, in ≤ 4 KiB writes.
        pending.clear();
        while i < frames.len()
            && Duration::from_secs_f64(frames[i].line_time_us as f64 * 1e-6 / speed) <= now
            && pending.len() < 4096
        {
            pending.extend_from_slice(&frames[i].bytes);
            i += 1;
        }
        write_all_patiently(out, &pending, stop, stall)?;
        written += pending.len() as u64;
    }
    Ok(written)
}

/// Writes all of `bytes`, in chunks of at most 4 KiB, waiting while the reader is slow or
/// not there yet (a pty's buffer is full: the write times out or would block), for at
/// most `stall` without progress.
fn write_all_patiently<W: Write + ?Sized>(
    out: &mut W,
    bytes: &[u8],
    stop: &AtomicBool,
    stall: Option<Duration>,
) -> io::Result<()> {
    let mut rest = bytes;
    let mut progress = Instant::now();
    while !rest.is_empty() {
        if stop.load(Ordering::Relaxed) {
            return Ok(());
        }
        let n = rest.len().min(4096);
        match out.write(&rest[..n]) {
            Ok(0) => return Err(io::Error::from(io::ErrorKind::WriteZero)),
            Ok(k) => {
                rest = &rest[k..];
                progress = Instant::now();
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) =>
            {
                if let Some(limit) = stall
                    && progress.elapsed() >= limit
                {
                    return Err(io::Error::new(
                        io::ErrorKind::TimedOut,
                        format!(
                            "no host read the port for {:.0} s ({} bytes still to send)",
                            limit.as_secs_f64(),
                            rest.len()
                        ),
                    ));
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => return Err(e),
        }
    }
    match out.flush() {
        Err(e) if e.kind() != io::ErrorKind::TimedOut && e.kind() != io::ErrorKind::WouldBlock => {
            Err(e)
        }
        _ => Ok(()),
    }
}

/// A pseudo-terminal pair for the simulated device: the master end (write the stream
/// here), the slave end (kept open so the path stays valid until a host opens it), and
/// the slave's path, which a host opens like a serial port.
#[cfg(unix)]
pub fn pty_pair() -> Result<(serialport::TTYPort, serialport::TTYPort, String), serialport::Error> {
    let (master, slave) = serialport::TTYPort::pair()?;
    let name = serialport::SerialPort::name(&slave).unwrap_or_default();
    Ok((master, slave, name))
}
