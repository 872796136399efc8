//! Where the residual is significant: along x, per line, run, direction, feed and over
//! time; which covariates it follows; which periods stand out. O(n) plus sorting.
//!
//! Every group statistic is a weighted mean (weights 1/σ² of the noise groups) with its
//! standard error from the same weights scaled by the final model's residual variance, so
//! z = mean/se is ~N(0, 1) where the model is complete. "before" is the residual about its
//! weighted mean (the free constant removed), "after" is the residual of the final model.

use serde::Serialize;

use super::data::Obs;

/// A group (bin) of rows and its mean residual before and after the model.
#[derive(Debug, Clone, Serialize)]
pub struct GroupStat {
    /// What the group is ("x 0–40 mm", "run 3", "direction +", "feed 50 mm/s").
    pub label: String,
    /// Rows in the group.
    pub rows: usize,
    /// Weighted mean residual before the model (about the overall mean), µm.
    pub mean_um: f64,
    /// Standard error of the mean, µm.
    pub se_um: f64,
    /// mean_um / se_um.
    pub z: f64,
    /// Weighted mean residual after the model, µm.
    pub mean_after_um: f64,
    /// mean_after_um / se_um.
    pub z_after: f64,
}

/// Weighted correlation of the residual with a covariate.
#[derive(Debug, Clone, Serialize)]
pub struct Correlation {
    /// The covariate.
    pub covariate: String,
    /// With the residual before the model.
    pub before: f64,
    /// With the residual after the model.
    pub after: f64,
}

/// A periodogram peak.
#[derive(Debug, Clone, Serialize)]
pub struct SpectralPeak {
    /// Period, µm.
    pub period_um: f64,
    /// Where the search looked ("P/2 of the 20 µm grating", "broad periodogram").
    pub source: String,
    /// Drop in χ² of a sine at this period (search subset).
    pub delta_chi2: f64,
}

/// The localisation of the mismatch.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Locate {
    /// Bins along the measured axis.
    pub along_x: Vec<GroupStat>,
    /// Per line (the two other coordinates).
    pub per_line: Vec<GroupStat>,
    /// Per run.
    pub per_run: Vec<GroupStat>,
    /// Per direction of travel.
    pub per_direction: Vec<GroupStat>,
    /// Direction-signed mean (d·r) of the moving rows per feed, and of the dwell rows.
    pub per_feed_signed: Vec<GroupStat>,
    /// Bins of time.
    pub over_time: Vec<GroupStat>,
    /// Correlations with the covariates, strongest (before) first.
    pub correlations: Vec<Correlation>,
    /// Periodogram peaks.
    pub spectral_peaks: Vec<SpectralPeak>,
    /// The above in words.
    pub findings: Vec<String>,
    /// Structure left after the model, in words (None: the residual is noise-like).
    pub unexplained: Option<String>,
}

/// Inputs of the localisation.
pub(crate) struct Input<'a> {
    pub obs: &'a Obs,
    pub before: &'a [f64],
    pub after: &'a [f64],
    pub w: &'a [f64],
    /// Residual variance scale of the final model (χ²/dof).
    pub s2: f64,
    pub peaks: Vec<SpectralPeak>,
    /// Pooled noise σ, µm.
    pub noise_sigma: f64,
}

fn stat(label: String, idx: &[usize], inp: &Input, signed: bool) -> Option<GroupStat> {
    if idx.is_empty() {
        return None;
    }
    let (mut sw, mut sb, mut sa) = (0.0, 0.0, 0.0);
    for &k in idx {
        let s = if signed { inp.obs.d[k] } else { 1.0 };
        sw += inp.w[k];
        sb += inp.w[k] * s * inp.before[k];
        sa += inp.w[k] * s * inp.after[k];
    }
    if sw <= 0.0 {
        return None;
    }
    let se = (inp.s2 / sw).sqrt();
    let (mb, ma) = (sb / sw, sa / sw);
    let z = |m: f64| if se > 0.0 { m / se } else { 0.0 };
    Some(GroupStat {
        label,
        rows: idx.len(),
        mean_um: mb,
        se_um: se,
        z: z(mb),
        mean_after_um: ma,
        z_after: z(ma),
    })
}

fn bins(v: &[f64], nb: usize) -> (Vec<Vec<usize>>, Vec<(f64, f64)>) {
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        });
    let width = ((hi - lo) / nb as f64).max(1e-12);
    let mut out = vec![Vec::new(); nb];
    for (k, &x) in v.iter().enumerate() {
        let b = (((x - lo) / width) as usize).min(nb - 1);
        out[b].push(k);
    }
    let edges = (0..nb)
        .map(|b| (lo + b as f64 * width, lo + (b + 1) as f64 * width))
        .collect();
    (out, edges)
}

fn corr(a: &[f64], b: &[f64], w: &[f64]) -> f64 {
    let sw: f64 = w.iter().sum();
    if sw <= 0.0 {
        return 0.0;
    }
    let ma = a.iter().zip(w).map(|(x, w)| x * w).sum::<f64>() / sw;
    let mb = b.iter().zip(w).map(|(x, w)| x * w).sum::<f64>() / sw;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for k in 0..a.len() {
        let (da, db) = (a[k] - ma, b[k] - mb);
        sab += w[k] * da * db;
        saa += w[k] * da * da;
        sbb += w[k] * db * db;
    }
    if saa > 0.0 && sbb > 0.0 {
        sab / (saa * sbb).sqrt()
    } else {
        0.0
    }
}
/// The residual's statistics per measured line, each labelled by its coordinates.
fn per_line(inp: &Input) -> Vec<GroupStat> {
    let obs = inp.obs;
    let n = obs.len();
    let mut out = Vec::new();
    let mut by_line = vec![Vec::new(); obs.lines.len()];
    for k in 0..n {
        by_line[obs.line[k]].push(k);
    }
    for (l, idx) in by_line.iter().enumerate() {
        // A coordinate no row carries (a session without MARKs giving it) is NaN in
        // `obs.lines`: said in words, not printed as a number.
        let coordinate = |name: &str, v: f64| {
            if v.is_finite() {
                format!("{name} = {v} mm")
            } else {
                format!("{name} not recorded")
            }
        };
        let [a, b] = obs.lines[l];
        let label = format!(
            "line {}, {}",
            coordinate(obs.c_axes[0].lower(), a),
            coordinate(obs.c_axes[1].lower(), b)
        );
        if let Some(s) = stat(label, idx, inp, false) {
            out.push(s);
        }
    }
    out
}

/// The direction-signed residual (d·r) while dwelling and at each feed: a latch delay
/// grows with the feed, a reversal does not.
fn per_feed_signed(inp: &Input) -> Vec<GroupStat> {
    let obs = inp.obs;
    let n = obs.len();
    let mut out = Vec::new();
    let mut feeds: Vec<i64> = (0..n)
        .filter(|&k| obs.moving[k])
        .map(|k| (obs.v_feed[k] * 1000.0).round() as i64)
        .collect();
    feeds.sort_unstable();
    feeds.dedup();
    let dwell: Vec<usize> = (0..n)
        .filter(|&k| !obs.moving[k] && obs.d[k] != 0.0)
        .collect();
    if let Some(s) = stat("dwell (d·r)".into(), &dwell, inp, true) {
        out.push(s);
    }
    for f in feeds {
        let idx: Vec<usize> = (0..n)
            .filter(|&k| {
                obs.moving[k] && obs.d[k] != 0.0 && (obs.v_feed[k] * 1000.0).round() as i64 == f
            })
            .collect();
        if let Some(s) = stat(
            format!("moving at {} mm/s (d·r)", f as f64 / 1000.0),
            &idx,
            inp,
            true,
        ) {
            out.push(s);
        }
    }
    out
}

/// The covariates the residual is correlated with: position, direction, feed, time, the
/// temperatures and the air (with their products with position where an effect has that
/// form), the line offsets.
fn covariates(obs: &super::data::Obs, ax: &str, lambda_um: f64) -> Vec<(String, Vec<f64>)> {
    let n = obs.len();
    let mut covs: Vec<(String, Vec<f64>)> = vec![
        (format!("{ax} (position)"), obs.x.clone()),
        ("direction".into(), obs.d.clone()),
        (
            "direction × feed".into(),
            (0..n).map(|k| obs.d[k] * obs.v_feed[k]).collect(),
        ),
        ("time".into(), obs.t.clone()),
    ];
    if let Some(ts) = &obs.scale_t {
        covs.push(("scale temperature".into(), ts.clone()));
        covs.push((
            format!("(scale T − 20)·{ax}"),
            (0..n).map(|k| (ts[k] - 20.0) * obs.x[k]).collect(),
        ));
    }
    if let Some(at) = &obs.air_t {
        covs.push(("air temperature".into(), at.clone()));
        covs.push((
            format!("air temperature·{ax}"),
            (0..n).map(|k| at[k] * obs.x[k]).collect(),
        ));
    }
    if let Some(ap) = &obs.air_p {
        covs.push(("air pressure".into(), ap.clone()));
    }
    if let Some(dn) = super::effects::index_change_ppm(obs, lambda_um) {
        covs.push(("air refractive index".into(), dn));
    }
    for c in 0..2 {
        if let Some(cv) = &obs.c[c] {
            let name = obs.c_axes[c].lower();
            covs.push((format!("{name} (line offset)"), cv.clone()));
            covs.push((
                format!("{name}·{ax}"),
                (0..n).map(|k| cv[k] * obs.x[k]).collect(),
            ));
        }
    }
    covs
}

/// Computes the localisation.
pub(crate) fn locate(inp: &Input, lambda_um: f64) -> Locate {
    let obs = inp.obs;
    let n = obs.len();
    let ax = super::data::axis_label(obs.axis).to_lowercase();
    let mut loc = Locate {
        spectral_peaks: inp.peaks.clone(),
        ..Locate::default()
    };

    let (xb, xe) = bins(&obs.x, 20);
    for (b, idx) in xb.iter().enumerate() {
        if let Some(s) = stat(
            format!(
                "{ax} {}–{} mm",
                super::fixed(xe[b].0, 1),
                super::fixed(xe[b].1, 1)
            ),
            idx,
            inp,
            false,
        ) {
            loc.along_x.push(s);
        }
    }
    loc.per_line = per_line(inp);
    let mut runs: Vec<u32> = obs.run.clone();
    runs.sort_unstable();
    runs.dedup();
    for &r in &runs {
        let idx: Vec<usize> = (0..n).filter(|&k| obs.run[k] == r).collect();
        if let Some(s) = stat(format!("run {r}"), &idx, inp, false) {
            loc.per_run.push(s);
        }
    }
    for (d, name) in [(1.0, "+"), (-1.0, "−"), (0.0, "none (outside runs)")] {
        let idx: Vec<usize> = (0..n).filter(|&k| obs.d[k] == d).collect();
        if let Some(s) = stat(format!("direction {name}"), &idx, inp, false) {
            loc.per_direction.push(s);
        }
    }
    loc.per_feed_signed = per_feed_signed(inp);
    let (tb, te) = bins(&obs.t, 20);
    for (b, idx) in tb.iter().enumerate() {
        if let Some(s) = stat(
            format!("t {:.0}–{:.0} s", te[b].0, te[b].1),
            idx,
            inp,
            false,
        ) {
            loc.over_time.push(s);
        }
    }

    // Correlations.
    let covs = covariates(obs, &ax, lambda_um);
    for (name, v) in covs {
        loc.correlations.push(Correlation {
            covariate: name,
            before: corr(inp.before, &v, inp.w),
            after: corr(inp.after, &v, inp.w),
        });
    }
    loc.correlations
        .sort_by(|a, b| b.before.abs().total_cmp(&a.before.abs()));

    loc.findings = findings(&loc);
    loc.unexplained = unexplained(&loc, inp.noise_sigma);
    loc
}

fn strongest(v: &[GroupStat], after: bool) -> Option<&GroupStat> {
    let key = |s: &GroupStat| if after { s.z_after.abs() } else { s.z.abs() };
    v.iter().max_by(|a, b| key(a).total_cmp(&key(b)))
}

fn findings(loc: &Locate) -> Vec<String> {
    let mut out = Vec::new();
    let sig = 5.0;
    let significant: Vec<&GroupStat> = loc.along_x.iter().filter(|s| s.z.abs() > sig).collect();
    if let (Some(first), Some(last)) = (significant.first(), significant.last()) {
        let m = strongest(&loc.along_x, false).map_or(0.0, |s| s.mean_um);
        out.push(format!(
            "along the axis the residual departs from its mean (|z| > {sig}) in {} of {} bins, from {} to {}; largest bin mean {m:+.3} µm",
            significant.len(),
            loc.along_x.len(),
            first.label,
            last.label
        ));
    }
    for (name, v) in [("line", &loc.per_line), ("run", &loc.per_run)] {
        if v.len() > 1
            && let Some(s) = strongest(v, false)
            && s.z.abs() > sig
        {
            out.push(format!(
                "the {name}s differ: {} has mean {:+.3} µm (z = {:.1})",
                s.label, s.mean_um, s.z
            ));
        }
    }
    let plus = loc.per_direction.iter().find(|s| s.label == "direction +");
    let minus = loc.per_direction.iter().find(|s| s.label == "direction −");
    if let (Some(p), Some(m)) = (plus, minus) {
        let diff = p.mean_um - m.mean_um;
        let se = p.se_um.hypot(m.se_um);
        if se > 0.0 && (diff / se).abs() > sig {
            out.push(format!(
                "the + and − directions differ by {diff:+.3} µm (z = {:.1})",
                diff / se
            ));
        }
    }
    let signed: Vec<String> = loc
        .per_feed_signed
        .iter()
        .filter(|s| s.z.abs() > sig)
        .map(|s| format!("{} {:+.3} µm", s.label, s.mean_um))
        .collect();
    if !signed.is_empty() {
        out.push(format!("direction-signed means: {}", signed.join(", ")));
    }
    if let (Some(a), Some(b)) = (loc.over_time.first(), loc.over_time.last()) {
        let se = a.se_um.hypot(b.se_um);
        let diff = b.mean_um - a.mean_um;
        if se > 0.0 && (diff / se).abs() > sig {
            out.push(format!(
                "over time the residual changes by {diff:+.3} µm from {} to {}",
                a.label, b.label
            ));
        }
    }
    let top: Vec<String> = loc
        .correlations
        .iter()
        .filter(|c| c.before.abs() > 0.3)
        .take(4)
        .map(|c| format!("{} (ρ = {:+.2})", c.covariate, c.before))
        .collect();
    if !top.is_empty() {
        out.push(format!(
            "the residual correlates most with {}",
            top.join(", ")
        ));
    }
    if out.is_empty() {
        out.push("no group of rows departs significantly from the mean residual".into());
    }
    out
}

/// Structure left after the model: groups (along x, over time, per direction, per line)
/// whose after-model means are jointly and individually far beyond noise (χ² excess > 8
/// standard deviations, one group beyond 6σ) and large enough to matter (that group's
/// mean at least the noise σ of one sample; smaller offsets, such as the counters'
/// quantisation at fixed targets, are not physics worth a verdict).
fn unexplained(loc: &Locate, noise_sigma: f64) -> Option<String> {
    let groups: Vec<&GroupStat> = loc
        .along_x
        .iter()
        .chain(&loc.over_time)
        .chain(&loc.per_direction)
        .chain(&loc.per_line)
        .collect();
    let dof = groups.len() as f64;
    if dof < 1.0 {
        return None;
    }
    let chi2: f64 = groups.iter().map(|s| s.z_after * s.z_after).sum();
    let excess = (chi2 - dof) / (2.0 * dof).sqrt();
    let worst = groups
        .iter()
        .max_by(|a, b| a.z_after.abs().total_cmp(&b.z_after.abs()))?;
    (excess > 8.0 && worst.z_after.abs() > 6.0 && worst.mean_after_um.abs() >= noise_sigma).then(|| {
        format!(
            "after the model the residual still departs from noise: {} has mean {:+.3} µm (z = {:.1}); χ² of the group means {chi2:.0} for {dof:.0} groups",
            worst.label, worst.mean_after_um, worst.z_after
        )
    })
}
