//! The ISO 10360-5 probing test's report (`acceptance iso10360-5 --report`): `report.md`,
//! `residuals.csv` and the map of the residuals on the sphere, one disc per stylus
//! (`sphere_map.png`/`.svg`: each stylus's hemisphere seen from its pole, every point's
//! residual of the judged fit magnified; see [`crate::plot::sphere_map`]).

use std::path::{Path, PathBuf};

use polars::prelude::*;

use super::ReportError;
use super::certificate::zone_words;
use super::md::Md;
use crate::acceptance::probing::frame;
use crate::acceptance::probing::{Judged, ProbingResult, Residual};
use crate::base::FileOp;
use crate::base::io_err;
use crate::plot::{MapPanel, MapPoint, SphereMap, sphere_map};

/// µm as every probing output prints them (1 nm).
pub(crate) fn um(v: f64) -> String {
    format!("{v:.3}")
}

/// mm as every probing output prints them (1 nm).
pub(crate) fn mm6(v: f64) -> String {
    format!("{v:.6}")
}

/// The 2010 and 2020 symbols of form, size and location for a single- or multi-stylus
/// test (ISO 10360-5:2010 / :2020), `_{…}` marking a subscript.
pub(crate) fn symbols(multi: bool) -> [(&'static str, &'static str); 3] {
    if multi {
        [
            ("P_{FTj}", "P_{Form.Sph.5×25:j:Tact}"),
            ("P_{STj}", "P_{Size.Sph.5×25:j:Tact}"),
            ("P_{LTj}", "L_{Dia.5×25:j:Tact}"),
        ]
    } else {
        [
            ("P_{FTU}", "P_{Form.Sph.1×25::Tact}"),
            ("P_{STU}", "P_{Size.Sph.1×25::Tact}"),
            ("—", "—"),
        ]
    }
}

/// A symbol for Markdown: `P_{FTU}` → `P<sub>FTU</sub>`.
fn md_symbol(s: &str) -> String {
    s.replace("_{", "<sub>").replace('}', "</sub>")
}

/// Each stylus's points as (θ, φ) about its pole — the mean direction of its points from
/// the all-points centre — with their residuals; and its largest θ.
pub(crate) fn map_points(r: &ProbingResult) -> Vec<(String, Vec<MapPoint>, f64)> {
    let c = r.fit.centre_mm;
    let dir = |p: &[f64; 3]| -> [f64; 3] {
        let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
            .sqrt()
            .max(f64::MIN_POSITIVE);
        [d[0] / n, d[1] / n, d[2] / n]
    };
    r.styli
        .iter()
        .map(|s| {
            let mine: Vec<&Residual> = r
                .residuals
                .iter()
                .filter(|x| x.stylus == s.stylus)
                .collect();
            let mut w = [0.0; 3];
            for x in &mine {
                let d = dir(&x.p_mm);
                (0..3).for_each(|k| w[k] += d[k]);
            }
            if (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt() < 1e-9 {
                w = [0.0, 0.0, 1.0];
            }
            let [u, v, w] = frame(w);
            let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            let pts: Vec<MapPoint> = mine
                .iter()
                .map(|x| {
                    let d = dir(&x.p_mm);
                    MapPoint {
                        theta_deg: dot(d, w).clamp(-1.0, 1.0).acos().to_degrees(),
                        phi_deg: dot(d, v).atan2(dot(d, u)).to_degrees().rem_euclid(360.0),
                        r_um: x.r_um,
                    }
                })
                .collect();
            let tmax = pts.iter().map(|p| p.theta_deg).fold(0.0, f64::max);
            (s.stylus.clone(), pts, tmax)
        })
        .collect()
}

/// Writes the report into `dir`: `report.md`, `residuals.csv`, `sphere_map.png`/`.svg`.
/// Returns the files, `report.md` first.
pub fn write_probing_report(
    dir: &Path,
    points_source: &str,
    sphere_source: &str,
    r: &ProbingResult,
) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(|e| ReportError::from(io_err(dir, FileOp::Write)(e)))?;
    let mut files = vec![dir.join("report.md")];
    files.push(residuals_csv(dir, r)?);
    let maps = map_points(r);
    files.extend(map(dir, r, &maps)?);
    super::write_text(&files[0], &markdown(points_source, sphere_source, r, &maps))?;
    Ok(files)
}

fn map(
    dir: &Path,
    r: &ProbingResult,
    maps: &[(String, Vec<MapPoint>, f64)],
) -> Result<Vec<PathBuf>, ReportError> {
    let panels = maps
        .iter()
        .zip(&r.styli)
        .map(|((name, pts, tmax), s)| MapPanel {
            title: format!("stylus {name}"),
            note: format!(
                "{} points to θ = {:.1}°; own fit: form {} µm, size {} µm",
                s.points,
                tmax,
                um(s.form_um),
                um(s.size_um)
            ),
            points: pts.clone(),
        })
        .collect();
    let chart = SphereMap {
        title: format!("{} {} test: residuals on the sphere", r.standard, r.test),
        notes: vec![
            format!(
                "least-squares sphere of all {} points: Ø {} mm; form {} µm, size {} µm; verdict {}",
                r.points,
                mm6(r.fit.diameter_mm),
                um(r.form.value_um),
                um(r.size.value_um),
                r.verdict
            ),
            "each disc: the stylus's hemisphere seen from its pole (centre θ = 0°, rim θ = 90°)"
                .to_string(),
        ],
        panels,
    };
    Ok(sphere_map(&dir.join("sphere_map"), &chart)?)
}

/// `residuals.csv`: row, stylus, point, x_mm, y_mm, z_mm, r_um (all-points fit).
fn residuals_csv(dir: &Path, r: &ProbingResult) -> Result<PathBuf, ReportError> {
    let csv = dir.join("residuals.csv");
    let x = &r.residuals;
    let coord = |k: usize| x.iter().map(|p| p.p_mm[k]).collect::<Vec<_>>();
    let mut df = DataFrame::new(
        x.len(),
        vec![
            Column::new(
                "row".into(),
                x.iter().map(|p| p.row as u64).collect::<Vec<_>>(),
            ),
            Column::new(
                "stylus".into(),
                x.iter().map(|p| p.stylus.clone()).collect::<Vec<_>>(),
            ),
            Column::new(
                "point".into(),
                x.iter().map(|p| p.point as u64).collect::<Vec<_>>(),
            ),
            Column::new("x_mm".into(), coord(0)),
            Column::new("y_mm".into(), coord(1)),
            Column::new("z_mm".into(), coord(2)),
            Column::new("r_um".into(), x.iter().map(|p| p.r_um).collect::<Vec<_>>()),
        ],
    )
    .map_err(|e| crate::table::format_err(&csv, e))?;
    crate::table::write_frame(&csv, &mut df)?;
    Ok(csv)
}

/// The header of [`result_rows`].
pub(crate) const RESULT_HEADER: [&str; 7] = [
    "quantity",
    "symbol (2010 / 2020)",
    "value / µm",
    "MPE / µm",
    "U / µm",
    "acceptance zone / µm",
    "verdict",
];

/// Form, size and (with several styli) location: quantity, symbols (`_{…}` subscripts),
/// value, MPE, U, acceptance zone, verdict.
pub(crate) fn result_rows(r: &ProbingResult) -> Vec<Vec<String>> {
    result_rows_in(r, &um)
}

/// [`result_rows`] with µm printed by `um`.
pub(crate) fn result_rows_in(r: &ProbingResult, um: &dyn Fn(f64) -> String) -> Vec<Vec<String>> {
    let sym = symbols(r.styli.len() > 1);
    let q = |name: &str, sy: (&str, &str), j: &Judged| {
        vec![
            name.to_string(),
            format!("{} / {}", sy.0, sy.1),
            um(j.value_um),
            um(j.mpe_um),
            um(j.u_um),
            zone_words(j.acceptance_um, um),
            j.verdict.to_string(),
        ]
    };
    let mut rows = vec![
        q("form", sym[0], &r.form),
        q("size (2r − D_{cal})", sym[1], &r.size),
    ];
    if let Some(l) = &r.location {
        rows.push(vec![
            "location".to_string(),
            format!("{} / {}", sym[2].0, sym[2].1),
            um(l.value_um),
            l.mpe_um.map_or("—".into(), um),
            um(l.u_um),
            l.acceptance_um.map_or("—".into(), |z| zone_words(z, um)),
            l.verdict.map_or("not judged".into(), |v| v.to_string()),
        ]);
    }
    rows
}

fn markdown(
    points_source: &str,
    sphere_source: &str,
    r: &ProbingResult,
    maps: &[(String, Vec<MapPoint>, f64)],
) -> String {
    let mut md = Md::new();
    md.heading(
        1,
        format_args!("{} — probing test ({})", r.standard, r.test),
    );
    md.para(format_args!(
        "Points: `{points_source}`; sphere: `{sphere_source}`"
    ));
    let loc = r
        .location
        .as_ref()
        .and_then(|l| l.verdict)
        .map(|v| format!(", location: {v}"))
        .unwrap_or_default();
    md.para(format_args!(
        "**Verdict: {}** (form: {}, size: {}{loc})",
        r.verdict, r.form.verdict, r.size.verdict
    ));
    md.para(&r.statement);
    md.heading(2, "Test sphere (its certificate)")
        .table_aligned(
            ["id", "D_cal / mm", "U(D) / µm", "F_s / µm", "U(F_s) / µm"],
            "lrrrr",
        );
    let s = &r.sphere;
    md.row([
        s.id.clone().unwrap_or_else(|| "—".into()),
        mm6(s.diameter_mm),
        um(s.u_diameter_um),
        um(s.form_um),
        um(s.u_form_um),
    ]);
    md.nl().heading(2, "Results");
    md.table_aligned(RESULT_HEADER, "llrrrll");
    for mut row in result_rows(r) {
        row[0] = md_symbol(&row[0]);
        row[1] = md_symbol(&row[1]);
        md.row(row);
    }
    md.nl().para(format_args!(
        "Least-squares sphere of all {} points: centre ({}, {}, {}) mm, Ø {} mm, rms of the \
         residuals {} µm.{}",
        r.points,
        mm6(r.fit.centre_mm[0]),
        mm6(r.fit.centre_mm[1]),
        mm6(r.fit.centre_mm[2]),
        mm6(r.fit.diameter_mm),
        um(r.fit.rms_um),
        r.location
            .as_ref()
            .map(|l| format!(
                " Ranges of the styli's centres: x {} µm, y {} µm, z {} µm.",
                um(l.axes_um[0]),
                um(l.axes_um[1]),
                um(l.axes_um[2])
            ))
            .unwrap_or_default()
    ));
    styli_table(&mut md, r, maps);
    md.nl().heading(2, "Deviations from the standard's design");
    if r.deviations.is_empty() {
        md.para("None: the number of styli, the 25 points per stylus and the sphere's diameter are the standard's.");
    } else {
        md.bullets(&r.deviations).nl();
    }
    let narrow: Vec<String> = r
        .styli
        .iter()
        .zip(maps)
        .filter(|(_, m)| m.2 < 85.0)
        .map(|(s, m)| format!("`{}` ({:.1}°)", s.stylus, m.2))
        .collect();
    if !narrow.is_empty() {
        md.para(format_args!(
            "Note: the points of stylus {} stay within a cap narrower than the standard's \
             hemisphere (largest angle from the pole in brackets). errmap evaluates a cap as \
             given; its size and centre are less well determined than a hemisphere's.",
            narrow.join(", ")
        ));
    }
    md.heading(2, "Residuals on the sphere")
        .para("![residuals on the sphere, one disc per stylus](sphere_map.png)")
        .line(
            "Each disc is one stylus's hemisphere seen from its pole (the mean direction of its points from the fitted centre): the distance from the centre is the angle θ from the pole, rings every 22.5°; the direction is the azimuth φ. Each point's residual of the least-squares sphere of all points (the one form and size are judged on) is a dot, red outside the sphere and blue inside, its radius proportional to |r| on one scale for every stylus, its value beside it in µm. `residuals.csv` lists them.",
        );
    md.finish()
}

/// The styli's own spheres, reported and not judged.
fn styli_table(md: &mut Md, r: &ProbingResult, maps: &[(String, Vec<MapPoint>, f64)]) {
    md.heading(
        2,
        "Styli (each on its own least-squares sphere; reported, not judged)",
    )
    .table_aligned(
        [
            "stylus",
            "points",
            "centre x / mm",
            "y / mm",
            "z / mm",
            "Ø / mm",
            "form / µm",
            "size / µm",
            "largest θ",
        ],
        "lrrrrrrrr",
    );
    for (st, (_, _, tmax)) in r.styli.iter().zip(maps) {
        md.row([
            st.stylus.clone(),
            st.points.to_string(),
            mm6(st.centre_mm[0]),
            mm6(st.centre_mm[1]),
            mm6(st.centre_mm[2]),
            mm6(st.diameter_mm),
            um(st.form_um),
            um(st.size_um),
            format!("{tmax:.1}°"),
        ]);
    }
}
