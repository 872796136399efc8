//! The transport seam: where bytes come from. A serial port (via `serialport`), or any
//! reader (a raw capture file for replay, a byte slice in tests), behind one small trait,
//! [`ByteSource`], so live capture, replay and the pseudo-terminal test device all feed
//! the same sans-IO [`Decoder`](crate::decoder::Decoder).
//!
//! Read semantics: [`ByteSource::read_bytes`] waits at most the source's timeout and
//! reports [`ReadOutcome::Data`], [`ReadOutcome::TimedOut`] (no byte within the timeout;
//! try again) or [`ReadOutcome::Eof`] (a file's end). A serial port that disappears (the
//! other end of a pty closed, a USB adapter unplugged) is [`TransportError::Vanished`].

use std::io::{self, Read, Write};
use std::time::Duration;

/// The byte a host sends to ask the device for a HELLO frame.
pub const HELLO_REQUEST: u8 = b'?';

/// Errors of the transport layer.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// The port could not be opened.
    #[error("cannot open serial port {path}: {source}")]
    Open {
        /// Port path.
        path: String,
        /// Why.
        #[source]
        source: serialport::Error,
    },
    /// The port went away while in use.
    #[error("serial port {path} vanished: {source}")]
    Vanished {
        /// Port path.
        path: String,
        /// The I/O error that showed it.
        #[source]
        source: io::Error,
    },
    /// Ports could not be listed.
    #[error("cannot list serial ports: {0}")]
    Enumerate(#[source] serialport::Error),
    /// Any other I/O error.
    #[error("I/O error: {0}")]
    Io(#[from] io::Error),
}

/// Result of one read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadOutcome {
    /// This many bytes were read into the start of the buffer (≥ 1 unless the buffer
    /// was empty).
    Data(usize),
    /// No byte arrived within the timeout.
    TimedOut,
    /// The source has no more bytes (end of a file).
    Eof,
}

/// A source of bytes with timeout semantics.
pub trait ByteSource {
    /// Read up to `buf.len()` bytes, waiting at most the source's timeout.
    fn read_bytes(&mut self, buf: &mut [u8]) -> Result<ReadOutcome, TransportError>;

    /// Send `bytes` to the device (the host's `?` asking for a HELLO). A read-only
    /// source (a file being replayed) ignores them; that is the default.
    fn send(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let _ = bytes;
        Ok(())
    }
}

/// A serial port opened by path.
pub struct SerialSource {
    path: String,
    port: Box<dyn serialport::SerialPort>,
}

impl std::fmt::Debug for SerialSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialSource")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

impl SerialSource {
    /// Open `path` at `baud` (8N1) with a read timeout.
    pub fn open(path: &str, baud: u32, timeout: Duration) -> Result<Self, TransportError> {
        let port = serialport::new(path, baud)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .timeout(timeout)
            .open()
            .map_err(|source| TransportError::Open {
                path: path.to_owned(),
                source,
            })?;
        Ok(SerialSource {
            path: path.to_owned(),
            port,
        })
    }

    /// The port's path.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Write bytes to the device (in chunks of at most 4 KiB: one large write into a full
    /// pty buffer would block past the timeout).
    pub fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        for chunk in bytes.chunks(4096) {
            self.port
                .write_all(chunk)
                .map_err(|e| classify(&self.path, e))?;
        }
        self.port.flush().map_err(|e| classify(&self.path, e))
    }

    /// Ask the device for a HELLO frame.
    pub fn request_hello(&mut self) -> Result<(), TransportError> {
        self.write_all(&[HELLO_REQUEST])
    }
}

/// An I/O error on the port at `path`: [`TransportError::Vanished`] when it means the port
/// is gone.
fn classify(path: &str, e: io::Error) -> TransportError {
    if is_vanished(&e) {
        TransportError::Vanished {
            path: path.to_owned(),
            source: e,
        }
    } else {
        TransportError::Io(e)
    }
}

/// One read, retried when interrupted: data, a timeout, or what `zero` makes of a
/// zero-length read into a non-empty buffer and `fail` of any other error.
fn read_once<R: Read + ?Sized>(
    r: &mut R,
    buf: &mut [u8],
    zero: impl FnOnce() -> Result<ReadOutcome, TransportError>,
    fail: impl FnOnce(io::Error) -> TransportError,
) -> Result<ReadOutcome, TransportError> {
    loop {
        return match r.read(buf) {
            Ok(0) if !buf.is_empty() => zero(),
            Ok(n) => Ok(ReadOutcome::Data(n)),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                ) =>
            {
                Ok(ReadOutcome::TimedOut)
            }
            Err(e) => Err(fail(e)),
        };
    }
}

/// I/O errors that mean the port is gone.
fn is_vanished(e: &io::Error) -> bool {
    let by_kind = matches!(
        e.kind(),
        io::ErrorKind::BrokenPipe
            | io::ErrorKind::NotConnected
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::UnexpectedEof
    );
    // EIO (5) on a hung-up tty, ENODEV (19) for an unplugged adapter.
    #[cfg(unix)]
    let by_errno = matches!(e.raw_os_error(), Some(5 | 19));
    #[cfg(not(unix))]
    let by_errno = false;
    by_kind || by_errno
}

impl ByteSource for SerialSource {
    fn send(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        use std::io::Write;
        self.port
            .write_all(bytes)
            .and_then(|()| self.port.flush())
            .map_err(|e| classify(&self.path, e))
    }

    fn read_bytes(&mut self, buf: &mut [u8]) -> Result<ReadOutcome, TransportError> {
        let path = &self.path;
        read_once(
            &mut self.port,
            buf,
            // A tty read of 0 bytes is a hang-up: the other end is gone.
            || {
                Err(TransportError::Vanished {
                    path: path.clone(),
                    source: io::Error::from(io::ErrorKind::UnexpectedEof),
                })
            },
            |e| classify(path, e),
        )
    }
}

/// Any reader as a byte source (a raw capture file for replay, a slice in tests).
#[derive(Debug)]
pub struct ReaderSource<R> {
    inner: R,
}

impl<R: Read> ReaderSource<R> {
    /// Wrap a reader.
    pub fn new(inner: R) -> Self {
        ReaderSource { inner }
    }

    /// The wrapped reader.
    pub fn into_inner(self) -> R {
        self.inner
    }
}

impl<R: Read> ByteSource for ReaderSource<R> {
    fn read_bytes(&mut self, buf: &mut [u8]) -> Result<ReadOutcome, TransportError> {
        read_once(
            &mut self.inner,
            buf,
            || Ok(ReadOutcome::Eof),
            TransportError::Io,
        )
    }
}

/// How a port is connected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PortKind {
    /// USB (details need serialport's default features, which this build leaves off).
    Usb,
    /// PCI, a permanent port.
    Pci,
    /// Bluetooth.
    Bluetooth,
    /// Unknown.
    Unknown,
}

/// A serial port found on the system.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct PortInfo {
    /// The path to open.
    pub name: String,
    /// How it is connected.
    pub kind: PortKind,
}

/// The serial ports of this system.
pub fn list_ports() -> Result<Vec<PortInfo>, TransportError> {
    let ports = serialport::available_ports().map_err(TransportError::Enumerate)?;
    Ok(ports
        .into_iter()
        .map(|p| PortInfo {
            name: p.port_name,
            kind: match p.port_type {
                serialport::SerialPortType::UsbPort(_) => PortKind::Usb,
                serialport::SerialPortType::PciPort => PortKind::Pci,
                serialport::SerialPortType::BluetoothPort => PortKind::Bluetooth,
                serialport::SerialPortType::Unknown => PortKind::Unknown,
            },
        })
        .collect())
}
