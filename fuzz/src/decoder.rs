//! The decoder target, on its own (it needs `errmap-drivers` only): the rows of a raw
//! capture must not depend on how the bytes are split, and must be finite.

use errmap_drivers::frame::DeviceId;
use errmap_drivers::{Hello, SessionDecoder, SessionRow};

/// Panics unless every value is finite; `what` names the values.
pub(super) fn finite(what: &str, values: &[f64]) {
    assert!(
        values.iter().all(|v| v.is_finite()),
        "{what}: a reader returned a non-finite value: {values:?}"
    );
}

/// Panics unless every value of a decoded row is finite.
pub(super) fn session_row_finite(r: &SessionRow) {
    let optional = [
        r.feed_mm_s,
        r.x_mm,
        r.y_mm,
        r.z_mm,
        r.air_temp_c,
        r.air_pressure_hpa,
        r.air_rh_pct,
        r.scale_temp_c,
        r.part_temp_c,
    ];
    finite("session row", &[r.t_s, r.scale_mm, r.laser_mm, r.error_um]);
    finite(
        "session row",
        &optional.into_iter().flatten().collect::<Vec<_>>(),
    );
}

/// A device description as replay's `--hello-from` gives it (the simulated board's: 20 µm
/// grating, 0.1 µm counts, HeNe, fold 2, ×4 edges, X), so that SAMPLEs before or without
/// a HELLO are converted too.
fn given_hello() -> Hello {
    Hello {
        protocol_version: 1,
        device_id: DeviceId::from_text("fuzz"),
        grating_period_nm: 20_000,
        count_resolution_pm: 100_000,
        laser_wavelength_fm: 632_991_354,
        optical_fold: 2,
        edges_per_fringe: 4,
        axis_code: 0,
    }
}

/// Decodes `data` whole and in two chunks split where its first byte says; the rows must
/// agree and be finite. Then once more with a device description given from the start.
pub(super) fn run(data: &[u8]) -> bool {
    if let Ok((rows, _, _)) = errmap_drivers::decode_all_with_hello(data, given_hello()) {
        rows.iter().for_each(session_row_finite);
    }
    let (rows, _stats, _hello) = errmap_drivers::decode_all(data);
    rows.iter().for_each(session_row_finite);
    let cut = data
        .first()
        .map_or(0, |&b| usize::from(b) * data.len() / 256);
    let mut d = SessionDecoder::new();
    let mut chunked = d.push(&data[..cut]);
    chunked.extend(d.push(&data[cut..]));
    chunked.extend(d.finish());
    assert_eq!(
        rows, chunked,
        "rows differ when the bytes arrive split at {cut}"
    );
    !rows.is_empty()
}
