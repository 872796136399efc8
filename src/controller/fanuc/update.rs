//! FANUC's in-place update ([`super::Fanuc`]'s [`crate::controller::Dialect::update`]):
//! its table holds increments, not values, so it does not go through the common update.

use super::FanucLayout;
use crate::controller::update::{Edit, Residual, UpdateSummary, Updated, apply, outside_warning};
use crate::controller::{ControllerTable, Field};

/// FANUC: the absolute curves (the sums of the increments from the reference position,
/// where the positive-travel curve is 0) get r in units of the table, less r at the
/// reference position (a datum offset the table cannot hold: warned about), are rounded
/// and differenced again; only the increments that change are rewritten, and 3627 when the
/// negative-travel curve moves at the reference position.
pub(super) fn update(
    table: &ControllerTable,
    layout: &FanucLayout,
    residual: &Residual,
    bidirectional: bool,
) -> Updated {
    let unit = layout.unit_um;
    let k0 = layout.reference_index;
    let mut outside_mm = Vec::new();
    // `None`: outside the measured targets, the point keeps its value.
    let r: Vec<Option<(f64, f64)>> = table
        .points
        .iter()
        .map(|p| {
            let r = residual.at(p.position_mm);
            if r.is_none() {
                outside_mm.push(p.position_mm);
            }
            r
        })
        .collect();
    let shift_um = r[k0].map_or(0.0, |r| r.0);
    let mut warnings = outside_warning(&outside_mm, residual);
    if shift_um != 0.0 {
        warnings.push(format!(
            "the residual at the reference position, {shift_um:.4} µm, is a datum offset \
             FANUC's pitch error table cannot hold (it is 0 there): it is left out"
        ));
    }
    let mut edits = Vec::new();
    let mut max_change_um: f64 = 0.0;
    let mut biggest: i64 = 0;
    // A kept point keeps its value in the table's own frame (relative to the reference
    // position): the datum shift applies only to the points the residual reaches. (Issue
    // 40: shifting a kept point by the shift turned its 0 into −1 µm on read-back.)
    let mut redo = |inc: &[(Field, i64)], old: &[f64], add: &dyn Fn(usize) -> Option<f64>| {
        let new: Vec<i64> = old
            .iter()
            .enumerate()
            .map(|(j, &a)| {
                let d = add(j).map_or(0.0, |r| r - shift_um);
                if d == 0.0 {
                    a as i64
                } else {
                    (a + d / unit).round() as i64
                }
            })
            .collect();
        for j in 0..new.len() {
            max_change_um = max_change_um.max((new[j] as f64 - old[j]).abs() * unit);
            if j > 0 {
                let v = new[j] - new[j - 1];
                biggest = biggest.max(v.abs());
                if v != inc[j - 1].1 {
                    edits.push(Edit {
                        field: inc[j - 1].0,
                        text: v.to_string(),
                        align: false,
                    });
                }
            }
        }
        new
    };
    let up: Vec<f64> = table.points.iter().map(|p| p.up_file).collect();
    redo(&layout.forward, &up, &|j| r[j].map(|r| r.0));
    if let Some((inc, (f3627, v3627))) = &layout.reverse {
        let down: Vec<f64> = table.points.iter().map(|p| p.down_file).collect();
        let new = redo(inc, &down, &|j| {
            r[j].map(|r| if bidirectional { r.1 } else { r.0 })
        });
        if new[k0] != *v3627 {
            edits.push(Edit {
                field: *f3627,
                text: new[k0].to_string(),
                align: false,
            });
        }
    }
    let limit = i64::from(super::FANUC_DEFAULT_MAX_VALUE);
    if biggest > limit {
        warnings.push(format!(
            "an increment of ±{biggest} units: beyond ±{limit}, the range of the older series; \
             check the control's limit"
        ));
    }
    let new_text = apply(&table.text.text, edits);
    Updated {
        bytes: table.text.encode(&new_text),
        summary: UpdateSummary {
            format: table.format.name(),
            points: table.points.len(),
            directions: if layout.reverse.is_some() { 2 } else { 1 },
            outside_mm,
            max_change_um,
            warnings,
        },
    }
}
