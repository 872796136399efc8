//! What the live view shows, as a plain struct updated from the decoder's events: no
//! terminal, no clock, no I/O, so it is tested by feeding it a simulated stream.
//!
//! Memory is bounded whatever the capture's length: the latest reading, counters, and the
//! per-target means of the last [`MAX_TRACES`] passes (a pass is one run in one
//! direction), each with at most [`MAX_TARGETS`] targets. When the run numbers start again
//! (the next line of a plan), the chart starts again.

use std::collections::{BTreeMap, VecDeque};

use errmap::drivers::frame::{Hello, SampleFlags};
use errmap::drivers::problem::ProblemKind;
use errmap::drivers::rotary::{RotaryAxis, RotaryRow};
use errmap::drivers::{Problem, SessionEvent, SessionRow};

/// Passes (run × direction) kept for the chart and the targets table.
pub(crate) const MAX_TRACES: usize = 8;
/// Targets kept per pass (a plan has tens; more would not be readable anyway).
pub(crate) const MAX_TARGETS: usize = 256;

/// What a capture measures: a linear axis (positions in mm, errors in µm) or a rotary
/// axis (angles in °, errors in ″). Every position and error of the view is in these.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) enum Units {
    #[default]
    Linear,
    Rotary(RotaryAxis),
}

impl Units {
    /// The unit of a position: "mm" or "°".
    pub(crate) fn position(self) -> &'static str {
        match self {
            Units::Linear => "mm",
            Units::Rotary(_) => "°",
        }
    }

    /// The unit of an error: "µm" or "″".
    pub(crate) fn error(self) -> &'static str {
        match self {
            Units::Linear => "µm",
            Units::Rotary(_) => "″",
        }
    }
}

/// The latest row's readings, in the capture's [`Units`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Reading {
    pub t_s: f64,
    pub run: u32,
    pub direction: i8,
    pub target: i32,
    /// The axis' own reading: a linear scale's position (mm) or a rotary encoder's angle (°).
    pub position: f64,
    /// The reference instrument's reading: the laser's length (mm) or the angle reference's (°).
    pub reference: f64,
    /// Axis − reference: µm, or ″ on a rotary axis.
    pub error: f64,
    pub air_temp_c: Option<f64>,
    pub air_pressure_hpa: Option<f64>,
    pub air_rh_pct: Option<f64>,
    pub scale_temp_c: Option<f64>,
    pub part_temp_c: Option<f64>,
    pub flags: u8,
}

/// Running sums of the clean samples dwelling at one target.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct TargetMean {
    pub n: u64,
    sum_pos: f64,
    sum_err: f64,
}

impl TargetMean {
    fn push(&mut self, pos: f64, err: f64) {
        self.n += 1;
        self.sum_pos += pos;
        self.sum_err += err;
    }

    /// Mean position, mm or ° (NaN before the first sample).
    pub(crate) fn position(&self) -> f64 {
        self.sum_pos / self.n as f64
    }

    /// Mean error, µm or ″.
    pub(crate) fn error(&self) -> f64 {
        self.sum_err / self.n as f64
    }
}

/// One pass: a run in one direction, with its targets' captured means.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Trace {
    pub run: u32,
    pub direction: i8,
    pub targets: BTreeMap<i32, TargetMean>,
}

impl Trace {
    /// "run 2 +" / "run 2 −".
    pub(crate) fn label(&self) -> String {
        format!("run {} {}", self.run, direction_sign(self.direction))
    }

    /// (mean position, mean error) per target, in target order.
    pub(crate) fn points(&self) -> Vec<(f64, f64)> {
        self.targets
            .values()
            .filter(|m| m.n > 0)
            .map(|m| (m.position(), m.error()))
            .collect()
    }
}

/// "+", "−" or "0".
pub(crate) fn direction_sign(d: i8) -> &'static str {
    match d.signum() {
        1 => "+",
        -1 => "−",
        _ => "0",
    }
}

/// One counter of the decoder's health, with when it last moved.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Counter {
    pub count: u64,
    /// Capture time (s, from the progress clock) of the last increase.
    pub changed_at_s: Option<f64>,
}

impl Counter {
    fn add(&mut self, n: u64, now_s: f64) {
        if n > 0 {
            self.count += n;
            self.changed_at_s = Some(now_s);
        }
    }
}

/// The decoder's health as the view shows it (counted from the problem events, so the
/// counts at the end equal the session's decoder statistics).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Health {
    pub crc_failures: Counter,
    /// Losses of alignment (one per run of skipped bytes).
    pub resyncs: Counter,
    pub bytes_skipped: u64,
    pub seq_gaps: Counter,
    pub frames_lost: u64,
    pub beam_low: Counter,
    pub overrun: Counter,
    /// Illegal scale or laser quadrature transitions.
    pub quadrature: Counter,
    /// Every other problem (bad lengths, unknown types, implausible ENV, …).
    pub other: Counter,
}

/// Everything the live view draws.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct ViewState {
    pub hello: Option<Hello>,
    /// Linear until a rotary board's first row.
    pub units: Units,
    pub latest: Option<Reading>,
    pub rows: u64,
    pub bytes: u64,
    /// Seconds since the capture started (the progress clock).
    pub elapsed_s: f64,
    pub health: Health,
    /// The last problem, in words, with its capture time.
    pub last_problem: Option<(f64, String)>,
    /// The passes of the current line, oldest first; the last is the current one.
    pub traces: VecDeque<Trace>,
    /// Distinct targets of the first complete pass (the plan's size, for "target k of N").
    pub targets_per_pass: Option<usize>,
}

impl ViewState {
    /// Takes one decoder event (rows, problems, HELLOs; TEXT lines are not shown).
    pub(crate) fn event(&mut self, e: &SessionEvent) {
        match e {
            SessionEvent::Row(r) => self.row(r),
            SessionEvent::Problem(p) => self.problem(p),
            SessionEvent::Hello(h) => self.hello = Some(*h),
            SessionEvent::Rotary(r) => self.rotary_row(r),
            SessionEvent::Text { .. } => {}
        }
    }

    /// A rotary board's row: its angle (°) and error (″) in the same readings and passes.
    fn rotary_row(&mut self, r: &RotaryRow) {
        self.units = Units::Rotary(r.axis);
        self.take(Reading {
            t_s: r.t_s,
            run: r.run,
            direction: r.direction,
            target: r.target,
            position: r.indicated_deg,
            reference: r.reference_deg,
            error: r.error_arcsec,
            air_temp_c: r.air_temp_c,
            air_pressure_hpa: None,
            air_rh_pct: None,
            scale_temp_c: r.scale_temp_c,
            part_temp_c: r.part_temp_c,
            flags: r.flags,
        });
    }

    /// The capture loop's clock and byte count.
    pub(crate) fn progress(&mut self, bytes: u64, elapsed_s: f64) {
        self.bytes = bytes;
        self.elapsed_s = elapsed_s;
    }

    fn row(&mut self, r: &SessionRow) {
        self.take(Reading {
            t_s: r.t_s,
            run: r.run,
            direction: r.direction,
            target: r.target,
            position: r.scale_mm,
            reference: r.laser_mm,
            error: r.error_um,
            air_temp_c: r.air_temp_c,
            air_pressure_hpa: r.air_pressure_hpa,
            air_rh_pct: r.air_rh_pct,
            scale_temp_c: r.scale_temp_c,
            part_temp_c: r.part_temp_c,
            flags: r.flags,
        });
    }

    /// One row's readings: the latest, and the passes' target means.
    fn take(&mut self, r: Reading) {
        self.rows += 1;
        self.latest = Some(r);
        if r.run == 0 || r.direction == 0 {
            return;
        }
        let same = self
            .traces
            .back()
            .is_some_and(|t| t.run == r.run && t.direction == r.direction);
        if !same {
            if self.targets_per_pass.is_none()
                && let Some(done) = self.traces.back()
                && !done.targets.is_empty()
            {
                self.targets_per_pass = Some(done.targets.len());
            }
            // Run numbers starting again: a new line (or test) begins, with a chart of
            // its own.
            if self.traces.back().is_some_and(|t| r.run < t.run) {
                self.traces.clear();
            }
            if self.traces.len() == MAX_TRACES {
                self.traces.pop_front();
            }
            self.traces.push_back(Trace {
                run: r.run,
                direction: r.direction,
                targets: BTreeMap::new(),
            });
        }
        // Dwelling, clean samples only: the reduction leaves flagged rows out too.
        if r.target < 0 || r.flags != 0 {
            return;
        }
        if let Some(t) = self.traces.back_mut()
            && (t.targets.len() < MAX_TARGETS || t.targets.contains_key(&r.target))
        {
            t.targets
                .entry(r.target)
                .or_default()
                .push(r.position, r.error);
        }
    }

    fn problem(&mut self, p: &Problem) {
        let now = self.elapsed_s;
        let h = &mut self.health;
        match &p.kind {
            ProblemKind::CrcFailure { .. } => h.crc_failures.add(1, now),
            ProblemKind::BytesSkipped { bytes } => {
                h.resyncs.add(1, now);
                h.bytes_skipped += bytes;
            }
            ProblemKind::SeqGap { lost, .. } => {
                h.seq_gaps.add(1, now);
                h.frames_lost += u64::from(*lost);
            }
            ProblemKind::FlaggedSample { flags } => {
                let f = SampleFlags(*flags);
                if f.contains(SampleFlags::BEAM_LOW) {
                    h.beam_low.add(1, now);
                }
                if f.contains(SampleFlags::OVERRUN) {
                    h.overrun.add(1, now);
                }
                if f.contains(SampleFlags::SCALE_QUAD_ERR | SampleFlags::LASER_QUAD_ERR) {
                    h.quadrature.add(1, now);
                }
            }
            _ => h.other.add(1, now),
        }
        self.last_problem = Some((now, format!("{} at byte {}", p.kind.name(), p.pos.offset)));
    }

    /// The current pass, if inside a run.
    pub(crate) fn current(&self) -> Option<&Trace> {
        let r = self.latest?;
        self.traces
            .back()
            .filter(|t| t.run == r.run && t.direction == r.direction)
    }

    /// The chart's data: one series of (position, mean error) per pass.
    pub(crate) fn chart(&self) -> Chart {
        Chart {
            series: self
                .traces
                .iter()
                .map(|t| Series {
                    label: t.label(),
                    points: t.points(),
                })
                .filter(|s| !s.points.is_empty())
                .collect(),
        }
    }
}

/// The chart's series, kept apart so a paused chart can hold still while the readings
/// go on.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Chart {
    pub series: Vec<Series>,
}

/// One pass on the chart.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Series {
    /// "run 2 −".
    pub label: String,
    /// (mean position, mean error) per target, in target order ([`Units`]).
    pub points: Vec<(f64, f64)>,
}

impl Chart {
    /// ((x min, x max), (y min, y max)) over every point, padded so single points and
    /// flat lines still get an axis; None when there is no point.
    pub(crate) fn bounds(&self) -> Option<((f64, f64), (f64, f64))> {
        let mut pts = self.series.iter().flat_map(|s| s.points.iter());
        let first = pts.next()?;
        let (mut x, mut y) = ((first.0, first.0), (first.1, first.1));
        for p in pts {
            x = (x.0.min(p.0), x.1.max(p.0));
            y = (y.0.min(p.1), y.1.max(p.1));
        }
        let pad = |(lo, hi): (f64, f64), min_span: f64| {
            let span = (hi - lo).max(min_span);
            let mid = 0.5 * (lo + hi);
            (mid - 0.55 * span, mid + 0.55 * span)
        };
        Some((pad(x, 1.0), pad(y, 0.1)))
    }
}
