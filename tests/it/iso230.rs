//! ISO 230-2 / VDI/DGQ 3441 positioning statistics: known answers worked out by hand
//! (and re-done independently in Python from the standard's formulas), the sign
//! convention, and the error cases.

use errmap::base::Direction;
use errmap::report::{iso230_markdown, iso230_plot};
use errmap::session::{AxisStats, IsoError, Observation, POSITION_TOL_MM, TargetStats, axis_stats};

/// Known answers are exact to rounding: a few ulps of values of order 10 µm.
const TOL_UM: f64 = 1e-12;

fn close(got: f64, want: f64, what: &str) {
    assert!(
        (got - want).abs() <= TOL_UM,
        "{what}: got {got:.15}, want {want:.15}"
    );
}

/// Observations of one target in one direction, runs numbered 1…, from errmap errors e.
fn runs(target: usize, position_mm: f64, direction: Direction, e_um: &[f64]) -> Vec<Observation> {
    e_um.iter()
        .zip(1..)
        .map(|(&e_um, run)| Observation {
            target,
            position_mm,
            run,
            direction,
            e_um,
        })
        .collect()
}

/// One target with both directions, from errmap errors e.
fn target(i: usize, position_mm: f64, e_up: &[f64], e_down: &[f64]) -> Vec<Observation> {
    let mut v = runs(i, position_mm, Direction::Up, e_up);
    v.extend(runs(i, position_mm, Direction::Down, e_down));
    v
}

/// 3 targets × 5 runs per direction, errors e = scale − laser in µm.
///
/// Worked by hand with x = −e (ISO deviation), s with n − 1:
///
/// target 1 (0 mm)
///   x↑ = [−1.0, −1.2, −0.8, −1.1, −0.9]: x̄↑ = −1.0, Σd² = 0.10, s↑ = √0.025 = 0.158114
///   x↓ = [−0.2, −0.4, 0.0, −0.3, −0.1]:  x̄↓ = −0.2, Σd² = 0.10, s↓ = √0.025
///   B = −1.0 − (−0.2) = −0.8, x̄ = −0.6, R↑ = R↓ = 4√0.025 = 0.632456,
///   R_i = max(2s↑ + 2s↓ + |B| = 1.432456, 0.632456, 0.632456) = 1.432456 (reversal branch)
///   Ps = 6·√0.025 = 0.948683
/// target 2 (100 mm)
///   x↑ = [1.5, −1.0, −2.5, 0.5, −0.5]:   x̄↑ = −0.4, Σd² = 9.2,  s↑ = √2.3 = 1.516575
///   x↓ = [−0.5, −3.5, 1.5, −1.5, 0.5]:   x̄↓ = −0.7, Σd² = 14.8, s↓ = √3.7 = 1.923538
///   B = 0.3, x̄ = −0.55, R↑ = 6.066300, R↓ = 7.694154,
///   R_i = max(2s↑ + 2s↓ + 0.3 = 7.180227, 6.066300, 7.694154) = 7.694154 (4s↓ branch)
///   Ps = 3(s↑ + s↓) = 10.320340
/// target 3 (200 mm)
///   x↑ = [4.0, 4.1, 3.9, 4.0, 4.0]:      x̄↑ = 4.0, Σd² = 0.02, s↑ = √0.005 = 0.070711
///   x↓ = [3.0, 3.1, 2.9, 3.2, 2.8]:      x̄↓ = 3.0, Σd² = 0.10, s↓ = √0.025 = 0.158114
///   B = 1.0, x̄ = 3.5, R↑ = 0.282843, R↓ = 0.632456, R_i = 0.141421 + 0.316228 + 1 = 1.457649
///   Ps = 3(s↑ + s↓) = 0.686474
fn three_targets() -> Vec<Observation> {
    let mut obs = target(
        1,
        0.0,
        &[1.0, 1.2, 0.8, 1.1, 0.9],
        &[0.2, 0.4, 0.0, 0.3, 0.1],
    );
    obs.extend(target(
        2,
        100.0,
        &[-1.5, 1.0, 2.5, -0.5, 0.5],
        &[0.5, 3.5, -1.5, 1.5, -0.5],
    ));
    obs.extend(target(
        3,
        200.0,
        &[-4.0, -4.1, -3.9, -4.0, -4.0],
        &[-3.0, -3.1, -2.9, -3.2, -2.8],
    ));
    obs
}

fn stats_of(obs: &[Observation]) -> AxisStats {
    match axis_stats(obs) {
        Ok(s) => s,
        Err(e) => panic!("axis_stats failed: {e}"),
    }
}

#[test]
fn three_targets_per_target_values_match_hand_computation() {
    let s = stats_of(&three_targets());
    let want: [(usize, f64, [f64; 12]); 3] = [
        // x̄↑, x̄↓, s↑, s↓, B, x̄, R↑, R↓, R_i, Ps, n↑, n↓
        (
            1,
            0.0,
            [
                -1.0,
                -0.2,
                0.025f64.sqrt(),
                0.025f64.sqrt(),
                -0.8,
                -0.6,
                4.0 * 0.025f64.sqrt(),
                4.0 * 0.025f64.sqrt(),
                4.0 * 0.025f64.sqrt() + 0.8,
                6.0 * 0.025f64.sqrt(),
                5.0,
                5.0,
            ],
        ),
        (
            2,
            100.0,
            [
                -0.4,
                -0.7,
                2.3f64.sqrt(),
                3.7f64.sqrt(),
                0.3,
                -0.55,
                4.0 * 2.3f64.sqrt(),
                4.0 * 3.7f64.sqrt(),
                4.0 * 3.7f64.sqrt(),
                3.0 * (2.3f64.sqrt() + 3.7f64.sqrt()),
                5.0,
                5.0,
            ],
        ),
        (
            3,
            200.0,
            [
                4.0,
                3.0,
                0.005f64.sqrt(),
                0.025f64.sqrt(),
                1.0,
                3.5,
                4.0 * 0.005f64.sqrt(),
                4.0 * 0.025f64.sqrt(),
                2.0 * 0.005f64.sqrt() + 2.0 * 0.025f64.sqrt() + 1.0,
                3.0 * (0.005f64.sqrt() + 0.025f64.sqrt()),
                5.0,
                5.0,
            ],
        ),
    ];
    assert_eq!(s.targets.len(), 3);
    for (t, (i, pos, w)) in s.targets.iter().zip(want) {
        assert_eq!(t.target, i);
        assert_eq!(t.position_mm, pos);
        let got = [
            t.mean_up_um,
            t.mean_down_um,
            t.s_up_um,
            t.s_down_um,
            t.reversal_um,
            t.mean_bidir_um,
            t.repeat_up_um,
            t.repeat_down_um,
            t.repeat_bidir_um,
            t.scatter_vdi_um,
            t.n_up as f64,
            t.n_down as f64,
        ];
        let names = [
            "x̄↑", "x̄↓", "s↑", "s↓", "B_i", "x̄_i", "R↑", "R↓", "R_i", "Ps_i", "n↑", "n↓",
        ];
        for ((g, w), name) in got.into_iter().zip(w).zip(names) {
            close(g, w, &format!("target {i} {name}"));
        }
    }
    // The decimal values quoted in the comment above (Python, independent arithmetic).
    close(s.targets[0].repeat_bidir_um, 1.4324555320336758, "R_1");
    close(s.targets[1].repeat_bidir_um, 7.694153624668537, "R_2");
    close(s.targets[2].repeat_bidir_um, 1.4576491222541477, "R_3");
    close(s.targets[1].scatter_vdi_um, 10.320340484932332, "Ps_2");
}

/// Axis values for the three-target example (hand computation, checked in Python):
///
/// B   = max|B_i| = max(0.8, 0.3, 1.0)                          = 1.0
/// B̄   = (−0.8 + 0.3 + 1.0)/3                                    = 0.166667
/// R↑  = max(0.632456, 6.066300, 0.282843)                       = 4√2.3  = 6.066300
/// R↓  = max(0.632456, 7.694154, 0.632456)                       = 4√3.7  = 7.694154
/// R   = max(1.432456, 7.694154, 1.457649)                       = 7.694154
/// E↑  = 4.0 − (−1.0)                                            = 5.0
/// E↓  = 3.0 − (−0.7)                                            = 3.7
/// E   = max(all 6 means) − min(all 6 means) = 4.0 − (−1.0)      = 5.0
/// M   = 3.5 − (−0.6)                                            = 4.1
/// A↑  = max(x̄↑ + 2s↑) − min(x̄↑ − 2s↑)
///     = (4 + 2√0.005) − (−0.4 − 2√2.3)                          = 7.574572
///       (the minimum is at target 2, not at target 1 where x̄↑ is lowest)
/// A↓  = (3 + 2√0.025) − (−0.7 − 2√3.7)                          = 7.863305
///       (the maximum is at target 3: 3.316228 > −0.7 + 2√3.7 = 3.147077)
/// A   = (4 + 2√0.005) − (−0.7 − 2√3.7)                          = 8.688498
/// VDI: Pa = M = 4.1; U max = 1.0; Ū = (0.8 + 0.3 + 1.0)/3 = 0.7;
///      Ps max = 10.320340; P̄s = (0.948683 + 10.320340 + 0.686474)/3 = 3.985166;
///      P = max(x̄_i + (U_i + Ps_i)/2) − min(x̄_i − (U_i + Ps_i)/2)
///        = (−0.55 + 5.310170) − (−0.55 − 5.310170)              = 10.620340
///        (both extremes at target 2, where the means are not extreme)
#[test]
fn three_targets_axis_values_match_hand_computation() {
    let s = stats_of(&three_targets());
    let r23 = 2.3f64.sqrt();
    let r37 = 3.7f64.sqrt();
    close(s.b_um, 1.0, "B");
    close(s.mean_reversal_um, 0.5 / 3.0, "B̄");
    close(s.r_up_um, 4.0 * r23, "R↑");
    close(s.r_down_um, 4.0 * r37, "R↓");
    close(s.r_um, 4.0 * r37, "R");
    close(s.e_up_um, 5.0, "E↑");
    close(s.e_down_um, 3.7, "E↓");
    close(s.e_um, 5.0, "E");
    close(s.m_um, 4.1, "M");
    close(
        s.a_up_um,
        (4.0 + 2.0 * 0.005f64.sqrt()) - (-0.4 - 2.0 * r23),
        "A↑",
    );
    close(
        s.a_down_um,
        (3.0 + 2.0 * 0.025f64.sqrt()) - (-0.7 - 2.0 * r37),
        "A↓",
    );
    close(
        s.a_um,
        (4.0 + 2.0 * 0.005f64.sqrt()) - (-0.7 - 2.0 * r37),
        "A",
    );
    // Decimal values from the independent Python computation.
    close(s.a_up_um, 7.574571533857929, "A↑ (python)");
    close(s.a_down_um, 7.863304578351107, "A↓ (python)");
    close(s.a_um, 8.688498168571577, "A (python)");

    let v = &s.vdi;
    close(v.pa_um, 4.1, "Pa");
    close(v.u_max_um, 1.0, "U max");
    close(v.u_mean_um, 0.7, "Ū");
    close(v.ps_max_um, 3.0 * (r23 + r37), "Ps max");
    close(v.ps_mean_um, 3.9851658221213557, "P̄s (python)");
    close(v.p_um, 0.3 + 3.0 * (r23 + r37), "P");
    close(v.p_um, 10.620340484932333, "P (python)");
}

/// R is the largest R_i wherever it is. Here (x = −e, 3 runs, s with n − 1):
///
/// target 1: x↑ = [10, 10.1, 9.9], x↓ = [9, 9.1, 8.9]: s = 0.1, B = 1.0 (largest |B|,
///           largest means), R_1 = 0.2 + 0.2 + 1.0 = 1.4
/// target 2: x↑ = [0, 0.8, 0.4], x↓ = [−0.2, 0.6, 0.2]: s = 0.4, B = 0.2,
///           R_2 = max(0.8 + 0.8 + 0.2, 1.6, 1.6) = 1.8
/// target 3: x↑ = [−5, −5.1, −4.9], x↓ = [−5.5, −5.6, −5.4]: s = 0.1, B = 0.5,
///           R_3 = 0.2 + 0.2 + 0.5 = 0.9 (smallest means)
///
/// So R = 1.8 at target 2. R at the argmax of the means or of |B| would give 1.4, at the
/// argmin 0.9, and max(R↑, R↓) — forgetting the bidirectional R_i — 1.6.
#[test]
fn r_is_the_largest_r_i_not_r_at_the_extreme_means() {
    let mut obs = target(1, 0.0, &[-10.0, -10.1, -9.9], &[-9.0, -9.1, -8.9]);
    obs.extend(target(2, 50.0, &[0.0, -0.8, -0.4], &[0.2, -0.6, -0.2]));
    obs.extend(target(3, 100.0, &[5.0, 5.1, 4.9], &[5.5, 5.6, 5.4]));
    let s = stats_of(&obs);

    let argmax_mean = s
        .targets
        .iter()
        .max_by(|a, b| a.mean_bidir_um.total_cmp(&b.mean_bidir_um))
        .map(|t| t.target);
    let argmax_b = s
        .targets
        .iter()
        .max_by(|a, b| a.reversal_um.abs().total_cmp(&b.reversal_um.abs()))
        .map(|t| t.target);
    assert_eq!(argmax_mean, Some(1));
    assert_eq!(argmax_b, Some(1));

    let r_i: Vec<f64> = s.targets.iter().map(|t| t.repeat_bidir_um).collect();
    close(r_i[0], 1.4, "R_1");
    close(r_i[1], 1.8, "R_2");
    close(r_i[2], 0.9, "R_3");
    close(s.r_um, 1.8, "R");
    close(s.r_up_um, 1.6, "R↑");
    close(s.r_down_um, 1.6, "R↓");
    assert!(s.r_um > s.r_up_um.max(s.r_down_um) + 0.1);
}

#[test]
fn positive_error_is_a_negative_iso_deviation() {
    // The scale reads 2 µm long going up and 1 µm long going down: e > 0.
    let mut obs = target(1, 10.0, &[2.0, 2.0, 2.0], &[1.0, 1.0, 1.0]);
    obs.extend(target(2, 20.0, &[2.0, 2.0, 2.0], &[1.0, 1.0, 1.0]));
    let s = stats_of(&obs);
    let t: &TargetStats = &s.targets[0];
    assert_eq!(t.mean_up_um, -2.0, "x̄↑ = −ē↑");
    assert_eq!(t.mean_down_um, -1.0, "x̄↓ = −ē↓");
    assert_eq!(t.mean_bidir_um, -1.5);
    // B_i = x̄↑ − x̄↓ = −2 − (−1) = −1: negative although ē↑ > ē↓.
    assert_eq!(t.reversal_um, -1.0);
    assert_eq!(s.mean_reversal_um, -1.0);
    // Ranges and maxima of absolute values do not care about the sign.
    assert_eq!(s.b_um, 1.0);
    assert_eq!(s.e_um, 1.0);
    assert_eq!(s.vdi.u_mean_um, 1.0);
    // Same data with e negated: the means flip, the axis ranges stay.
    let flipped: Vec<Observation> = obs
        .iter()
        .map(|o| Observation {
            e_um: -o.e_um,
            ..*o
        })
        .collect();
    let f = stats_of(&flipped);
    assert_eq!(f.targets[0].mean_up_um, 2.0);
    assert_eq!(f.targets[0].reversal_um, 1.0);
    assert_eq!(
        (f.b_um, f.e_um, f.a_um, f.r_um),
        (s.b_um, s.e_um, s.a_um, s.r_um)
    );
}

/// Runs need not be balanced: x↑ = [1, 3] (x̄↑ = 2, s↑ = √2), x↓ = [0, 1, 2]
/// (x̄↓ = 1, s↓ = 1). B = 1, R_i = max(2√2 + 2 + 1, 4√2, 4) = 3 + 2√2 = 5.828427.
/// With one target: E = 1, M = 0, A = (2 + 2√2) − (1 − 2) = 3 + 2√2.
#[test]
fn unbalanced_runs_use_their_own_n() {
    let obs = target(7, 12.5, &[-1.0, -3.0], &[0.0, -1.0, -2.0]);
    let s = stats_of(&obs);
    let t = &s.targets[0];
    assert_eq!((t.target, t.n_up, t.n_down), (7, 2, 3));
    close(t.mean_up_um, 2.0, "x̄↑");
    close(t.s_up_um, 2f64.sqrt(), "s↑");
    close(t.mean_down_um, 1.0, "x̄↓");
    close(t.s_down_um, 1.0, "s↓");
    close(t.repeat_bidir_um, 3.0 + 2.0 * 2f64.sqrt(), "R_i");
    close(s.e_um, 1.0, "E");
    close(s.m_um, 0.0, "M");
    close(s.a_um, 3.0 + 2.0 * 2f64.sqrt(), "A");
}

#[test]
fn order_of_observations_does_not_matter() {
    let obs = three_targets();
    let mut shuffled = obs.clone();
    shuffled.reverse();
    // A fixed interleaving as well (deterministic, no RNG needed).
    shuffled.rotate_left(7);
    assert_eq!(stats_of(&obs), stats_of(&shuffled));
}

#[test]
fn constant_offset_moves_means_only() {
    let obs = three_targets();
    let shifted: Vec<Observation> = obs
        .iter()
        .map(|o| Observation {
            e_um: o.e_um + 50.0,
            ..*o
        })
        .collect();
    let (a, b) = (stats_of(&obs), stats_of(&shifted));
    for (x, y) in a.targets.iter().zip(&b.targets) {
        assert!((y.mean_bidir_um - (x.mean_bidir_um - 50.0)).abs() < 1e-9);
    }
    for (x, y, name) in [
        (a.r_um, b.r_um, "R"),
        (a.e_um, b.e_um, "E"),
        (a.m_um, b.m_um, "M"),
        (a.a_um, b.a_um, "A"),
        (a.b_um, b.b_um, "B"),
        (a.vdi.p_um, b.vdi.p_um, "P"),
    ] {
        assert!((x - y).abs() < 1e-9, "{name}: {x} vs {y}");
    }
}

#[test]
fn empty_input_is_an_error() {
    assert_eq!(axis_stats(&[]), Err(IsoError::Empty));
}

#[test]
fn non_finite_values_are_errors() {
    let mut obs = three_targets();
    obs[4].e_um = f64::NAN;
    assert_eq!(
        axis_stats(&obs),
        Err(IsoError::NonFinite {
            index: 4,
            target: 1,
            what: "e_um"
        })
    );
    let mut obs = three_targets();
    obs[12].position_mm = f64::INFINITY;
    assert_eq!(
        axis_stats(&obs),
        Err(IsoError::NonFinite {
            index: 12,
            target: 2,
            what: "position_mm"
        })
    );
}

#[test]
fn a_target_with_fewer_than_two_runs_in_a_direction_is_an_error() {
    // One run down at target 2: s↓ undefined.
    let mut obs = target(1, 0.0, &[1.0, 2.0], &[1.0, 2.0]);
    obs.extend(target(2, 10.0, &[1.0, 2.0], &[1.0]));
    let err = axis_stats(&obs);
    assert_eq!(
        err,
        Err(IsoError::TooFewRuns {
            target: 2,
            direction: Direction::Down,
            runs: 1
        })
    );
    let text = err.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(text.contains("target 2") && text.contains("down"), "{text}");
    // No runs up at all.
    let obs = runs(3, 0.0, Direction::Down, &[1.0, 2.0, 3.0]);
    assert_eq!(
        axis_stats(&obs),
        Err(IsoError::TooFewRuns {
            target: 3,
            direction: Direction::Up,
            runs: 0
        })
    );
}

#[test]
fn inconsistent_positions_for_one_target_are_an_error() {
    let mut obs = three_targets();
    // Within the tolerance is fine…
    obs[3].position_mm += 0.5 * POSITION_TOL_MM;
    assert!(axis_stats(&obs).is_ok());
    // …beyond it is not.
    obs[3].position_mm = 0.01;
    assert_eq!(
        axis_stats(&obs),
        Err(IsoError::InconsistentPosition {
            target: 1,
            first_mm: 0.0,
            other_mm: 0.01,
            index: 3
        })
    );
}

#[test]
fn a_run_repeated_in_one_direction_is_an_error() {
    let mut obs = three_targets();
    obs[6].run = obs[5].run; // target 1, both down
    assert_eq!(
        axis_stats(&obs),
        Err(IsoError::DuplicateRun {
            target: 1,
            direction: Direction::Down,
            run: 1
        })
    );
}

#[test]
fn markdown_has_the_table_the_symbols_and_the_sign_convention() {
    let s = stats_of(&three_targets());
    let md = iso230_markdown(&s, "X");
    for needle in [
        "axis X",
        "x = P_ij − P_i",
        "= −e",
        "| target i | P_i mm | n↑ | n↓ | x̄_i↑ | x̄_i↓ | B_i | 2s_i↑ | 2s_i↓ | R_i↑ | R_i↓ | R_i |",
        "| 2 | 100 | 5 | 5 | -0.400 | -0.700 | 0.300 | 3.033 | 3.847 | 6.066 | 7.694 | 7.694 |",
        "| accuracy of positioning | A | 7.575 | 7.863 | 8.688 |",
        "| repeatability of positioning | R | 6.066 | 7.694 | 7.694 |",
        "| systematic positional deviation | E | 5.000 | 3.700 | 5.000 |",
        "| mean bidirectional positional deviation | M | — | — | 4.100 |",
        "| reversal value | B | — | — | 1.000 |",
        "| mean reversal value | B̄ | — | — | 0.167 |",
        "P = 10.620 µm",
        "Pa = 4.100 µm",
        "Ps max = 10.320 µm",
        "U max = 1.000 µm",
    ] {
        assert!(md.contains(needle), "markdown lacks {needle:?}:\n{md}");
    }
    assert!(!md.contains("fewer than the 5 runs"), "{md}");
    // A short test is flagged.
    let short = stats_of(&target(1, 0.0, &[1.0, 2.0], &[1.0, 2.0, 3.0]));
    assert!(iso230_markdown(&short, "Y").contains("fewest: 2"));
}

#[test]
fn stats_serialise_to_json_with_the_vdi_block() -> Result<(), serde_json::Error> {
    let s = stats_of(&three_targets());
    let v = serde_json::to_value(&s)?;
    assert_eq!(v["targets"].as_array().map(Vec::len), Some(3));
    assert_eq!(v["b_um"], 1.0);
    assert_eq!(v["targets"][0]["target"], 1);
    assert!(v["vdi"]["p_um"].is_number());
    let back: Observation = serde_json::from_value(serde_json::to_value(three_targets()[0])?)?;
    assert_eq!(back, three_targets()[0]);
    Ok(())
}

#[test]
fn plot_writes_png_and_svg() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    let stem = dir.path().join("iso230_x");
    let s = stats_of(&three_targets());
    let paths = iso230_plot(&s, &stem, "Axis X, ISO 230-2 deviations")?;
    assert_eq!(paths.len(), 2);
    assert!(paths[0].ends_with("iso230_x.png") && paths[1].ends_with("iso230_x.svg"));
    let png = std::fs::read(&paths[0])?;
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let svg = std::fs::read_to_string(&paths[1])?;
    for text in [
        "Axis X, ISO 230-2 deviations",
        "mean x↑ + 2s↑",
        "mean x↓ − 2s↓",
        "µm",
    ] {
        assert!(svg.contains(text), "SVG lacks {text:?}");
    }
    Ok(())
}

/// Issue 35: `table` into a report folder used before for a session with more lines left
/// the earlier lines' figures there, read as this session's. They are gone; the report's
/// own figures and anything else in the folder stay.
#[test]
fn a_reused_report_folder_keeps_no_figures_of_an_earlier_session() {
    use crate::util::{dataset, errmap};
    let dir = tempfile::tempdir().expect("tempdir");
    let report = dir.path().join("r");
    let s = |p: &std::path::Path| p.to_str().expect("utf8").to_string();
    let four = errmap(&[
        "table",
        &s(&dataset("physics/example-session.parquet")),
        "--out",
        &s(&dir.path().join("e4.csv")),
        "--report",
        &s(&report),
    ]);
    assert!(
        four.status.success(),
        "{}",
        String::from_utf8_lossy(&four.stderr)
    );
    assert!(report.join("line4.png").exists());
    std::fs::write(report.join("notes.txt"), "mine").expect("a file of the user's");
    let one = dir.path().join("s.csv");
    let o = errmap(&[
        "import",
        &s(&dataset("examples/x-axis.pos")),
        "--out",
        &s(&one),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = errmap(&[
        "table",
        &s(&one),
        "--out",
        &s(&dir.path().join("e1.csv")),
        "--report",
        &s(&report),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(report.join("line1.png").exists() && report.join("line1.svg").exists());
    for n in 2..=4 {
        for ext in ["png", "svg"] {
            assert!(
                !report.join(format!("line{n}.{ext}")).exists(),
                "line{n}.{ext} is stale"
            );
        }
    }
    assert_eq!(
        std::fs::read_to_string(report.join("notes.txt")).expect("kept"),
        "mine"
    );
}
