//! Helpers shared by the diagnosis test binaries.

use errmap::diagnose::Diagnosis;

/// A diagnosis in words for assertion messages: verdict, effects, ambiguities, design
/// notes and the selection log.
pub(crate) fn diagnosis_text(d: &Diagnosis) -> String {
    let mut s = format!(
        "verdict {} rms {:.4} → {:.4} (cv {:.4}), noise {:.4}\n",
        d.verdict, d.rms_before_um, d.rms_after_um, d.cv_rms_after_um, d.noise_sigma_um
    );
    for e in &d.effects {
        s.push_str(&format!(
            "  {} {:?} ± {:?} explains {:.4}\n    where: {}\n",
            e.id(),
            e.effect.params(),
            e.uncertainty,
            e.explains_um,
            e.where_
        ));
    }
    for (tag, lines) in [
        ("ambiguity", &d.ambiguities),
        ("design", &d.design_notes),
        ("log", &d.selection_log),
    ] {
        for a in lines {
            s.push_str(&format!("  {tag}: {a}\n"));
        }
    }
    s
}
