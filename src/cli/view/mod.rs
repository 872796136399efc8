//! The live view of `capture` on a terminal (ratatui on crossterm, drawn on stderr).
//!
//! Two threads. The reading thread runs the capture exactly as without a view (raw bytes
//! on disk first, fsync ≤ 1 s, rows to the session table); the decoder events the writer
//! consumes also update a [`state::ViewState`] (O(1) per event), and every
//! [`FRAME`] the capture's progress tick offers a copy of it to a one-slot mailbox
//! ([`Latest`]) with `try_lock`: the reader never waits for the terminal. The drawing
//! thread takes the newest copy, reads keys and draws at most once per [`FRAME`]
//! (≤ 10 Hz); a slow or resized terminal delays only the drawing, never a byte.
//!
//! Keys: `q` or Ctrl-C stop the capture cleanly (the session is written as on any stop);
//! `p` or space pause the chart (the readings and counters go on).

pub(crate) mod draw;
#[cfg(test)]
pub(crate) mod snapshot;
pub(crate) mod state;

use std::cell::RefCell;
use std::io::{Stderr, stderr};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
use crossterm::execute;
use crossterm::terminal::{
    EnterAlternateScreen, LeaveAlternateScreen, disable_raw_mode, enable_raw_mode,
};
use errmap::acquire::{self, SessionPaths};
use errmap::drivers::ByteSource;
use errmap::drivers::capture::{CaptureConfig, Captured};
use ratatui::Terminal;
use ratatui::backend::CrosstermBackend;

use state::{Chart, ViewState};

/// Shortest time between two drawings, and between two state copies: ≤ 10 Hz.
pub(crate) const FRAME: Duration = Duration::from_millis(100);

/// A one-slot mailbox holding the newest value: the writer replaces, the reader takes.
/// Neither waits: a busy slot makes [`Latest::offer`] skip this value (a newer one follows).
#[derive(Debug, Default)]
pub(crate) struct Latest<T> {
    slot: Mutex<Option<T>>,
}

impl<T> Latest<T> {
    /// Puts `v` in the slot unless the other side holds it right now; whether it did.
    pub(crate) fn offer(&self, v: T) -> bool {
        match self.slot.try_lock() {
            Ok(mut g) => {
                *g = Some(v);
                true
            }
            Err(_) => false,
        }
    }

    /// The newest value, if one came since the last take.
    pub(crate) fn take(&self) -> Option<T> {
        self.slot.lock().ok()?.take()
    }
}

type Term = Terminal<CrosstermBackend<Stderr>>;

/// Raw mode and the alternate screen on stderr; left again on drop (also when the drawing
/// thread fails).
#[derive(Debug)]
struct Screen;

/// The terminal, ready for the live view ([`open`]).
pub(crate) struct Live {
    screen: Screen,
    term: Term,
}

impl std::fmt::Debug for Live {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Live").finish_non_exhaustive()
    }
}

/// Takes the terminal (raw mode, alternate screen on stderr) for [`capture`]; an error
/// leaves it as it was, and the caller captures without the view.
pub(crate) fn open() -> Result<Live> {
    enable_raw_mode().context("cannot put the terminal in raw mode")?;
    let screen = Screen;
    execute!(stderr(), EnterAlternateScreen).context("cannot open the alternate screen")?;
    let term = Terminal::new(CrosstermBackend::new(stderr())).context("cannot draw on stderr")?;
    Ok(Live { screen, term })
}

/// Sets its flag when dropped: the drawing thread ends even if the capture panics.
struct SetOnDrop<'a>(&'a AtomicBool);

impl Drop for SetOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::SeqCst);
    }
}

impl Drop for Screen {
    fn drop(&mut self) {
        let _ = execute!(stderr(), LeaveAlternateScreen, crossterm::cursor::Show);
        let _ = disable_raw_mode();
    }
}

/// Captures from `source` into `paths` with the live view on the terminal (see the module
/// docs). `stop` is the capture's stop flag (Ctrl-C's too); `q` sets it.
pub(crate) fn capture(
    live: Live,
    source: &mut dyn ByteSource,
    paths: &SessionPaths,
    config: &CaptureConfig,
    stop: &AtomicBool,
) -> Result<Captured> {
    let Live { screen, term } = live;
    let config = CaptureConfig {
        progress_every: FRAME,
        ..*config
    };
    let slot = Latest::<ViewState>::default();
    let done = AtomicBool::new(false);
    let state = RefCell::new(ViewState::default());
    let (captured, drawn) = std::thread::scope(|sc| {
        let ui = sc.spawn(|| {
            let _screen = screen;
            ui_loop(term, &slot, &done, stop)
        });
        let finished = SetOnDrop(&done);
        let captured = acquire::capture_session_watched(
            source,
            paths,
            &config,
            stop,
            &mut |p| {
                let mut s = state.borrow_mut();
                s.progress(p.bytes, p.elapsed_s);
                slot.offer(s.clone());
            },
            &mut |e| state.borrow_mut().event(e),
        );
        drop(finished);
        (captured, ui.join())
    });
    match drawn {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            eprintln!("capture: the live view stopped drawing ({e}); the capture went on")
        }
        Err(_) => eprintln!("capture: the live view failed; the capture went on"),
    }
    Ok(captured?)
}

/// The drawing thread: keys, the newest state, a drawing at most every [`FRAME`].
fn ui_loop(
    mut term: Term,
    slot: &Latest<ViewState>,
    done: &AtomicBool,
    stop: &AtomicBool,
) -> std::io::Result<()> {
    let mut state = ViewState::default();
    let mut paused: Option<Chart> = None;
    let mut dirty = true;
    let mut last_draw: Option<Instant> = None;
    term.clear()?;
    while !done.load(Ordering::SeqCst) {
        if event::poll(FRAME / 2)? {
            match event::read()? {
                Event::Key(k) if k.kind == KeyEventKind::Press => match k.code {
                    KeyCode::Char('q') => stop.store(true, Ordering::SeqCst),
                    KeyCode::Char('c') if k.modifiers.contains(KeyModifiers::CONTROL) => {
                        stop.store(true, Ordering::SeqCst);
                    }
                    KeyCode::Char('p' | ' ') => {
                        paused = match paused {
                            Some(_) => None,
                            None => Some(state.chart()),
                        };
                        dirty = true;
                    }
                    _ => {}
                },
                Event::Resize(..) => dirty = true,
                _ => {}
            }
        }
        if let Some(s) = slot.take() {
            state = s;
            dirty = true;
        }
        if dirty && last_draw.is_none_or(|t| t.elapsed() >= FRAME) {
            term.draw(|f| draw::draw(f, &state, paused.as_ref()))?;
            last_draw = Some(Instant::now());
            dirty = false;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
