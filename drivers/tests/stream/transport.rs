//! The transport seam: a reader (replay) and a serial port on a pseudo-terminal pair.

use std::io::Write;
use std::time::Duration;

use errmap_drivers::transport::{ByteSource, ReadOutcome, ReaderSource, SerialSource, list_ports};
use errmap_drivers::{SessionDecoder, TransportError};

use crate::common::{Stream, hello, sample};

fn small_stream() -> Vec<u8> {
    let mut s = Stream::new(0);
    s.frame(&hello(0));
    for i in 0..50 {
        s.frame(&sample(
            u64::from(i) * 100,
            i,
            i as i32 * 3,
            i as i32 * 4,
            0,
        ));
    }
    s.bytes
}

/// Drain a source into a session decoder until EOF or `idle_timeouts` timeouts in a row.
fn drain(src: &mut dyn ByteSource, idle_timeouts: usize) -> (usize, Option<TransportError>) {
    let mut d = SessionDecoder::new();
    let mut rows = 0;
    let mut buf = [0u8; 37];
    let mut idle = 0;
    loop {
        match src.read_bytes(&mut buf) {
            Ok(ReadOutcome::Data(n)) => {
                idle = 0;
                rows += d.push(&buf[..n]).len();
            }
            Ok(ReadOutcome::TimedOut) => {
                idle += 1;
                if idle >= idle_timeouts {
                    break;
                }
            }
            Ok(ReadOutcome::Eof) => break,
            Err(e) => {
                rows += d.finish().len();
                return (rows, Some(e));
            }
        }
    }
    rows += d.finish().len();
    (rows, None)
}

#[test]
fn reader_source_replays_to_eof() {
    let bytes = small_stream();
    let mut src = ReaderSource::new(bytes.as_slice());
    let (rows, err) = drain(&mut src, 1);
    assert!(err.is_none());
    assert_eq!(rows, 50);
}

#[cfg(unix)]
#[test]
fn serial_source_on_a_pty_pair() {
    let (mut master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let path = serialport::SerialPort::name(&slave).expect("slave path");
    let mut src = SerialSource::open(&path, 115_200, Duration::from_millis(50)).expect("open pty");
    let bytes = small_stream();
    for chunk in bytes.chunks(1024) {
        master.write_all(chunk).expect("write");
    }
    master.flush().expect("flush");
    let (rows, err) = drain(&mut src, 3);
    assert!(err.is_none(), "{err:?}");
    assert_eq!(rows, 50);
    // The host can ask for a HELLO; the device end sees the '?'.
    src.request_hello().expect("write ?");
    let mut one = [0u8; 1];
    std::io::Read::read_exact(&mut master, &mut one).expect("read ?");
    assert_eq!(one[0], b'?');
    drop(slave);
}

#[cfg(unix)]
#[test]
fn vanished_port_is_reported() {
    let (master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let path = serialport::SerialPort::name(&slave).expect("slave path");
    let mut src = SerialSource::open(&path, 115_200, Duration::from_millis(50)).expect("open pty");
    drop(slave);
    drop(master);
    let mut buf = [0u8; 16];
    let mut outcome = None;
    for _ in 0..20 {
        match src.read_bytes(&mut buf) {
            Ok(ReadOutcome::TimedOut) => continue,
            other => {
                outcome = Some(other);
                break;
            }
        }
    }
    assert!(
        matches!(outcome, Some(Err(TransportError::Vanished { .. }))),
        "{outcome:?}"
    );
}

#[test]
fn opening_a_missing_port_is_a_typed_error() {
    let err = SerialSource::open(
        "/dev/errmap-no-such-port",
        115_200,
        Duration::from_millis(10),
    )
    .expect_err("no such port");
    assert!(matches!(err, TransportError::Open { .. }));
    assert!(err.to_string().contains("/dev/errmap-no-such-port"));
}

#[test]
fn listing_ports_does_not_fail() {
    // Containers may have no serial port at all; the call itself must work.
    let _ = list_ports().expect("list ports");
}
