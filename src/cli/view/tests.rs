//! The live view without a human: the state fed by a simulated stream agrees with the
//! decoder's statistics and with target means computed straight from the rows; the
//! drawing (ratatui's `TestBackend`) shows the readings, the counters and a chart whose
//! lines go where the data go. `ERRMAP_WRITE_SCREENSHOT=1 cargo test --bin errmap view::`
//! also writes the README's screenshot, `reports/live-view/screen.txt` and `screen.png`.

#![allow(clippy::unwrap_used)]

use std::collections::BTreeMap;
use std::path::PathBuf;

use errmap::drivers::frame::SampleFlags;
use errmap::drivers::sim::{Faults, SimStream};
use errmap::drivers::{Axis, SessionDecoder, SessionEvent, SessionRow};
use ratatui::Terminal;
use ratatui::backend::TestBackend;

use super::state::{Chart, MAX_TRACES, ViewState};
use super::{Latest, draw, snapshot};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn stream(faults: &Faults) -> SimStream {
    let (s, _) = errmap::sim::simulate_stream(
        &root().join("datasets/sim/model.toml"),
        Some(&root().join("datasets/sim/plan.toml")),
        faults,
    )
    .unwrap();
    s
}

fn faulty() -> Faults {
    Faults {
        garbage_prob: 0.002,
        bit_flip_prob: 0.002,
        drop_prob: 0.002,
        beam_loss_s: Some((3.0, 3.2)),
        seed: 7,
        ..Faults::default()
    }
}

/// Feeds the stream's bytes in 4 KiB reads, as the capture loop does; returns the view's
/// state, every row, and the decoder's statistics.
fn feed(s: &SimStream) -> (ViewState, Vec<SessionRow>, errmap::drivers::DecoderStats) {
    feed_part(s, 1.0)
}

/// [`feed`] of the first `part` of the stream, the clock following the bytes.
fn feed_part(
    s: &SimStream,
    part: f64,
) -> (ViewState, Vec<SessionRow>, errmap::drivers::DecoderStats) {
    let mut bytes: Vec<u8> = s.frames.iter().flat_map(|f| f.bytes.clone()).collect();
    let total = bytes.len() as f64;
    bytes.truncate((total * part) as usize);
    let mut d = SessionDecoder::new();
    let mut view = ViewState::default();
    let mut rows = Vec::new();
    let mut take = |view: &mut ViewState, e: SessionEvent| {
        view.event(&e);
        if let SessionEvent::Row(r) = e {
            rows.push(r);
        }
    };
    let mut sent = 0u64;
    for chunk in bytes.chunks(4096) {
        d.push_with(chunk, &mut |e| take(&mut view, e));
        sent += chunk.len() as u64;
        view.progress(sent, s.duration_s * sent as f64 / total);
    }
    if part >= 1.0 {
        d.finish_with(&mut |e| take(&mut view, e));
    }
    (view, rows, d.stats())
}

fn text(state: &ViewState, paused: Option<&Chart>, w: u16, h: u16) -> Vec<String> {
    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
    t.draw(|f| draw::draw(f, state, paused)).unwrap();
    let buf = t.backend().buffer();
    (0..h)
        .map(|y| (0..w).map(|x| buf[(x, y)].symbol()).collect::<String>())
        .collect()
}

fn line_with<'a>(screen: &'a [String], what: &str) -> &'a str {
    screen
        .iter()
        .find(|l| l.contains(what))
        .unwrap_or_else(|| panic!("no line with {what:?} in\n{}", screen.join("\n")))
}

/// The number right after `label` on its line.
fn number_after(screen: &[String], label: &str) -> f64 {
    let l = line_with(screen, label);
    let rest = &l[l.find(label).unwrap() + label.len()..];
    rest.split_whitespace().next().unwrap().parse().unwrap()
}

fn close(shown: f64, value: f64, half_digit: f64) {
    assert!(
        (shown - value).abs() <= half_digit * (1.0 + 1e-9),
        "shown {shown}, value {value}"
    );
}

/// The chart's part of the screen (right of the left column).
fn chart_part(screen: &[String]) -> String {
    screen
        .iter()
        .map(|l| l.chars().skip(46).collect::<String>())
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn health_counters_equal_the_decoder_statistics() {
    let (view, rows, stats) = feed(&stream(&faulty()));
    let h = &view.health;
    // The faults happened (else this test proves nothing).
    assert!(stats.crc_failures > 0 && stats.resyncs > 0 && stats.seq_gaps > 0);
    assert_eq!(h.crc_failures.count, stats.crc_failures);
    assert_eq!(h.resyncs.count, stats.resyncs);
    assert_eq!(h.bytes_skipped, stats.bytes_skipped);
    assert_eq!(h.seq_gaps.count, stats.seq_gaps);
    assert_eq!(h.frames_lost, stats.frames_lost);
    let beam_low = rows
        .iter()
        .filter(|r| SampleFlags(r.flags).contains(SampleFlags::BEAM_LOW))
        .count() as u64;
    assert!(beam_low > 0);
    assert_eq!(h.beam_low.count, beam_low);
    assert_eq!(view.rows, rows.len() as u64);
    assert_eq!(view.latest.unwrap().t_s, rows.last().unwrap().t_s);
}

#[test]
fn target_means_equal_the_means_of_the_rows() {
    let (view, rows, _) = feed(&stream(&Faults::default()));
    // Straight from the rows: clean samples dwelling at a target, per pass, in order.
    // ((run, direction), target → (Σ position, Σ error, n)).
    type Sums = BTreeMap<i32, (f64, f64, u64)>;
    let mut passes: Vec<((u32, i8), Sums)> = Vec::new();
    let mut lines = 0;
    for r in rows.iter().filter(|r| r.run > 0 && r.direction != 0) {
        if passes.last().is_none_or(|p| p.0 != (r.run, r.direction)) {
            if passes.last().is_some_and(|p| r.run < p.0.0) {
                // The plan's next line: the view's chart starts again.
                passes.clear();
                lines += 1;
            }
            passes.push(((r.run, r.direction), BTreeMap::new()));
        }
        if r.target >= 0 && r.flags == 0 {
            let e = passes.last_mut().unwrap().1.entry(r.target).or_default();
            e.0 += r.scale_mm;
            e.1 += r.error_um;
            e.2 += 1;
        }
    }
    // Four lines of two runs out and back.
    assert_eq!((lines, passes.len()), (3, 4));
    let kept = &passes[passes.len().saturating_sub(MAX_TRACES)..];
    assert_eq!(view.traces.len(), kept.len());
    for (t, (key, targets)) in view.traces.iter().zip(kept) {
        assert_eq!((t.run, t.direction), *key);
        assert_eq!(t.targets.len(), targets.len());
        assert_eq!(t.targets.len(), 5, "the plan's five targets");
        for ((k, m), (k2, (sx, se, n))) in t.targets.iter().zip(targets) {
            assert_eq!((k, m.n), (k2, *n));
            assert!((m.position() - sx / *n as f64).abs() < 1e-9);
            assert!((m.error() - se / *n as f64).abs() < 1e-9);
        }
    }
    assert_eq!(view.targets_per_pass, Some(5));
}

#[test]
fn the_drawing_shows_readings_progress_counters_and_chart() {
    let (view, rows, stats) = feed(&stream(&faulty()));
    let screen = text(&view, None, 120, 40);
    let all = screen.join("\n");
    let last = rows.last().unwrap();
    // Readings: the last row's values, as printed.
    close(number_after(&screen, "│position"), last.scale_mm, 0.5e-4);
    close(number_after(&screen, "│laser"), last.laser_mm, 0.5e-4);
    close(number_after(&screen, "│error"), last.error_um, 0.5e-3);
    close(
        number_after(&screen, "│air"),
        last.air_temp_c.unwrap(),
        0.5e-2,
    );
    // The refractive index in use: a room's air, ~2.7e-4 above 1 at 633 nm.
    let n = number_after(&screen, "│n air");
    assert!((1.000_25..1.000_29).contains(&n), "n = {n}");
    // Counters: the decoder's own statistics.
    assert_eq!(
        number_after(&screen, "│CRC failures"),
        stats.crc_failures as f64
    );
    assert_eq!(number_after(&screen, "│resyncs"), stats.resyncs as f64);
    assert_eq!(number_after(&screen, "│seq gaps"), stats.seq_gaps as f64);
    assert_eq!(
        number_after(&screen, "│beam low"),
        view.health.beam_low.count as f64
    );
    assert!(
        line_with(&screen, "│seq gaps").contains(&format!("({} frames lost)", stats.frames_lost))
    );
    // Progress: the last pass and its targets' means.
    let t = view.traces.back().unwrap();
    assert_eq!(last.run, 0, "the plan ends outside any run");
    assert!(line_with(&screen, "│outside any run").contains("outside"));
    assert!(
        screen
            .iter()
            .any(|l| l.contains(&t.label()) && l.contains("e µm")),
        "{all}"
    );
    let (k, m) = t.targets.iter().next().unwrap();
    let row = line_with(&screen, &format!("target{:>2}", k + 1));
    assert!(row.contains(&format!("{:.3}", m.error())), "{row}");
    // Chart: every kept pass in the legend, braille dots drawn.
    let chart = chart_part(&screen);
    for t in &view.traces {
        assert!(
            chart.contains(&t.label()),
            "legend {} missing:\n{all}",
            t.label()
        );
    }
    let dots = all
        .chars()
        .filter(|c| ('\u{2801}'..='\u{28ff}').contains(c))
        .count();
    assert!(dots > 50, "{dots} braille cells:\n{all}");
}

/// A rotary board (B axis, eccentricity 4″ and reversal 3″, errmap's simulated rotary
/// board and its default cycle): the view takes its rows in ° and ″ — the passes' target
/// means are the rows' dwell means — and draws them with those units, never mm or µm.
#[test]
fn a_rotary_board_is_shown_in_degrees_and_arcseconds() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("rot.toml");
    std::fs::write(
        &model,
        "[rotary]\naxis = \"B\"\nseed = 5\n\n[[rotary.effects]]\nid = \"eccentricity\"\n\
         amplitude_arcsec = 4.0\nphase_deg = 30.0\n\n[[rotary.effects]]\nid = \"reversal\"\n\
         b_arcsec = 3.0\n",
    )
    .unwrap();
    let s = errmap::sim::simulate_rotary_stream(&model, None).unwrap();
    let bytes: Vec<u8> = s.frames.iter().flat_map(|f| f.bytes.clone()).collect();
    // Stop inside the last run, so the view has a current reading at a target.
    let part = &bytes[..bytes.len() * 9 / 10];
    let mut d = SessionDecoder::new();
    let mut view = ViewState::default();
    let mut rows = Vec::new();
    d.push_with(part, &mut |e| {
        view.event(&e);
        if let SessionEvent::Rotary(r) = e {
            rows.push(r);
        }
    });
    assert!(rows.len() > 500, "{} rotary rows", rows.len());
    assert_eq!(view.units.error(), "″");
    assert_eq!(view.rows, rows.len() as u64);
    // The passes' target means: the rows' own dwell means.
    for t in &view.traces {
        for (k, m) in &t.targets {
            let dwell: Vec<_> = rows
                .iter()
                .filter(|r| (r.run, r.direction, r.target) == (t.run, t.direction, *k))
                .filter(|r| r.flags == 0)
                .collect();
            let n = dwell.len() as f64;
            assert_eq!(m.n as usize, dwell.len());
            let deg = dwell.iter().map(|r| r.indicated_deg).sum::<f64>() / n;
            let sec = dwell.iter().map(|r| r.error_arcsec).sum::<f64>() / n;
            assert!((m.position() - deg).abs() < 1e-9 && (m.error() - sec).abs() < 1e-9);
        }
    }
    assert!(view.traces.iter().map(|t| t.targets.len()).sum::<usize>() > 20);
    let screen = text(&view, None, 120, 40);
    let all = screen.join("\n");
    let last = rows.last().unwrap();
    let value = |label: &str| -> f64 {
        let l = line_with(&screen, label);
        let rest = &l[l.find(label).unwrap() + label.len()..];
        let v = rest.split_whitespace().next().unwrap();
        v.trim_end_matches(['°', '″']).parse().unwrap()
    };
    close(value("│angle"), last.indicated_deg, 0.5e-4);
    close(value("│reference"), last.reference_deg, 0.5e-4);
    close(value("│error"), last.error_arcsec, 0.5e-2);
    assert!(line_with(&screen, "│error").contains('″'));
    assert!(all.contains("axis B (rotary)"), "{all}");
    assert!(all.contains("θ °") && all.contains("e ″"), "{all}");
    assert!(all.contains("error ″ against angle °"), "{all}");
    assert!(!all.contains("µm") && !all.contains(" mm"), "{all}");
}

/// Rows of one pass dwelling at `n` targets with error = slope · position.
fn pass(run: u32, direction: i8, slope: f64) -> Vec<SessionRow> {
    (0..5)
        .map(|k| {
            let x = 100.0 * f64::from(k);
            SessionRow {
                run,
                sample: i64::from(k),
                t_s: f64::from(k),
                axis: Axis::X,
                direction,
                feed_mm_s: Some(100.0),
                target: k,
                x_mm: Some(x),
                y_mm: None,
                z_mm: None,
                scale_mm: x,
                laser_mm: x - slope * x / 1000.0,
                error_um: slope * x,
                air_temp_c: None,
                air_pressure_hpa: None,
                air_rh_pct: None,
                scale_temp_c: None,
                part_temp_c: None,
                flags: 0,
            }
        })
        .collect()
}

/// (column, row) of every braille cell with dots, right of column `from`.
fn braille_cells(screen: &[String], from: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (y, l) in screen.iter().enumerate() {
        for (x, c) in l.chars().enumerate() {
            if x >= from && ('\u{2801}'..='\u{28ff}').contains(&c) {
                out.push((x, y));
            }
        }
    }
    out
}

#[test]
fn the_chart_rises_where_the_error_rises_and_a_paused_chart_holds_still() {
    let mut view = ViewState::default();
    for r in pass(1, 1, 0.02) {
        view.event(&SessionEvent::Row(r));
    }
    let screen = text(&view, None, 120, 40);
    let cells = braille_cells(&screen, 46);
    let left = cells.iter().min_by_key(|c| c.0).unwrap();
    let right = cells.iter().max_by_key(|c| c.0).unwrap();
    // Error 0 at x = 0, 8 µm at x = 400: the line climbs (rows count down the screen).
    assert!(right.0 > left.0 + 30, "{left:?} {right:?}");
    assert!(
        right.1 + 15 < left.1,
        "{left:?} {right:?}\n{}",
        screen.join("\n")
    );
    // The axes span the data.
    assert!(line_with(&screen, "x mm").contains("x mm"));
    let all = screen.join("\n");
    assert!(all.contains("run 1 +") && !all.contains("run 1 −"));
    assert!(chart_part(&screen).contains("run 1 +"));
    // Paused: a falling second pass arrives, the paused chart still shows only the first.
    let frozen = view.chart();
    for r in pass(1, -1, -0.02) {
        view.event(&SessionEvent::Row(r));
    }
    let paused_screen = text(&view, Some(&frozen), 120, 40);
    let paused = paused_screen.join("\n");
    assert!(paused.contains("PAUSED"), "{paused}");
    let paused_chart = chart_part(&paused_screen);
    assert!(
        paused_chart.contains("run 1 +") && !paused_chart.contains("run 1 −"),
        "{paused_chart}"
    );
    let live = text(&view, None, 120, 40);
    assert!(chart_part(&live).contains("run 1 −"));
    assert!(!live.join("\n").contains("PAUSED"));
    // The readings went on while the chart was paused: the last row is the − pass's.
    assert!(
        paused.contains("run 1 −  dwelling at target 5 of 5"),
        "{paused}"
    );
}

#[test]
fn the_view_keeps_the_last_passes_only() {
    let mut view = ViewState::default();
    for run in 1..=6 {
        for d in [1, -1] {
            for r in pass(run, d, 0.01 * f64::from(run)) {
                view.event(&SessionEvent::Row(r));
            }
        }
    }
    assert_eq!(view.traces.len(), MAX_TRACES);
    let first = view.traces.front().unwrap();
    assert_eq!(
        (first.run, first.direction),
        (3, 1),
        "12 passes, the last 8 kept"
    );
    // A new line: runs start again at 1, and so does the chart.
    for r in pass(1, 1, 0.0) {
        view.event(&SessionEvent::Row(r));
    }
    assert_eq!(view.traces.len(), 1);
}

#[test]
fn a_small_terminal_draws_without_panicking() {
    let (view, _, _) = feed(&stream(&faulty()));
    for (w, h) in [(1, 1), (20, 5), (46, 12), (80, 24)] {
        let screen = text(&view, None, w, h);
        assert_eq!(screen.len(), h as usize);
    }
}

#[test]
fn the_mailbox_keeps_the_newest_value_and_never_waits() {
    let slot = Latest::default();
    assert!(slot.offer(1));
    assert!(slot.offer(2));
    assert_eq!(slot.take(), Some(2));
    assert_eq!(slot.take(), None);
    // While the drawing side holds the slot, the reader skips instead of waiting.
    let held = slot.slot.lock().unwrap();
    assert!(!slot.offer(3));
    drop(held);
    assert_eq!(slot.take(), None);
}

fn buffer(state: &ViewState, w: u16, h: u16) -> ratatui::buffer::Buffer {
    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
    t.draw(|f| draw::draw(f, state, None)).unwrap();
    t.backend().buffer().clone()
}

#[test]
fn screenshot_for_the_readme() {
    // Mid-plan: the last line's second run, on its way back.
    let (view, _, _) = feed_part(&stream(&faulty()), 0.95);
    let screen = text(&view, None, 120, 36);
    let body: Vec<String> = screen.iter().map(|l| l.trim_end().to_string()).collect();
    let body = body.join("\n");
    assert!(body.contains("Decoder health") && body.contains("Readings"));
    if std::env::var_os("ERRMAP_WRITE_SCREENSHOT").is_some() {
        let dir = root().join("reports/live-view");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("screen.txt"), body + "\n").unwrap();
        snapshot::write_png(&buffer(&view, 120, 36), &dir.join("screen.png")).unwrap();
    }
}

/// The picture shows each cell in its colours: a red counter's box has red pixels, a
/// green one's green, every Braille dot of the chart sits where its bit says, and cells
/// drawn as blanks stay background.
#[test]
fn the_screenshot_picture_shows_each_cells_colours_and_dots() {
    use plotters::prelude::*;
    let (view, _, _) = feed_part(&stream(&faulty()), 0.95);
    let buf = buffer(&view, 120, 36);
    let (w, h) = snapshot::size(&buf);
    let mut pixels = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        snapshot::paint(&root, &buf).unwrap();
        root.present().unwrap();
    }
    let at = |x: i32, y: i32| {
        let k = ((y as u32 * w + x as u32) * 3) as usize;
        (pixels[k], pixels[k + 1], pixels[k + 2])
    };
    let cell_has = |cx: u16, cy: u16, want: RGBColor| {
        let (px, py) = (
            i32::from(cx) * snapshot::CELL_W as i32,
            i32::from(cy) * snapshot::CELL_H as i32,
        );
        // A glyph's pixels blend its colour into the background, p = bg + a·(fg − bg):
        // some pixel of the cell must be at least half the colour, in every channel alike.
        let bg = [28.0_f64, 28.0, 28.0];
        let fg = [f64::from(want.0), f64::from(want.1), f64::from(want.2)];
        (0..snapshot::CELL_H as i32).any(|dy| {
            (0..snapshot::CELL_W as i32).any(|dx| {
                let (r, g, b) = at(px + dx, py + dy);
                let p = [f64::from(r), f64::from(g), f64::from(b)];
                let k = (0..3)
                    .max_by(|&i, &j| (fg[i] - bg[i]).abs().total_cmp(&(fg[j] - bg[j]).abs()))
                    .unwrap();
                let a = (p[k] - bg[k]) / (fg[k] - bg[k]);
                a >= 0.5 && (0..3).all(|i| (p[i] - bg[i] - a * (fg[i] - bg[i])).abs() < 16.0)
            })
        })
    };
    let (mut red, mut green, mut dots) = (0, 0, 0);
    for y in 0..buf.area.height {
        for x in 0..buf.area.width {
            let cell = &buf[(x, y)];
            let ch = cell.symbol().chars().next().unwrap_or(' ');
            if let Some(bits) = snapshot::braille_dots(ch) {
                let fg = snapshot::rgb(cell.fg).unwrap();
                let (px, py) = (
                    i32::from(x) * snapshot::CELL_W as i32,
                    i32::from(y) * snapshot::CELL_H as i32,
                );
                for cx in 0..2 {
                    for cy in 0..4 {
                        let (dx, dy) = snapshot::dot_origin(px, py, cx, cy);
                        let lit = at(dx, dy) == (fg.0, fg.1, fg.2);
                        assert_eq!(
                            lit,
                            bits.contains(&(cx, cy)),
                            "dot ({cx},{cy}) of {ch:?} at ({x},{y})"
                        );
                    }
                }
                dots += 1;
                continue;
            }
            // Letters and digits fill their box; punctuation may be a hairline.
            if !ch.is_alphanumeric() || cell.modifier.contains(ratatui::style::Modifier::REVERSED) {
                continue;
            }
            match cell.fg {
                ratatui::style::Color::Red => {
                    assert!(
                        cell_has(x, y, snapshot::rgb(cell.fg).unwrap()),
                        "red {ch:?} at ({x},{y})"
                    );
                    red += 1;
                }
                ratatui::style::Color::Green => {
                    assert!(
                        cell_has(x, y, snapshot::rgb(cell.fg).unwrap()),
                        "green {ch:?} at ({x},{y})"
                    );
                    green += 1;
                }
                _ => {}
            }
        }
    }
    // The faulty stream's counters: some red (faults seen), some green (none of a kind).
    assert!(
        red > 0 && green > 0 && dots > 50,
        "red {red}, green {green}, dots {dots}"
    );
    assert_eq!(
        at(w as i32 - 1, h as i32 - 1),
        (0x1c, 0x1c, 0x1c),
        "background"
    );
}
