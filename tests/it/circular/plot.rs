//! The polar plot read back: the two directions' colours sit where the trace puts them.

use errmap::circular::simulate;
use errmap::circular::{DiagnoseConfig, Plane, diagnose};
use errmap::plot::{colour, pixel};
use errmap::report::{CCW_COLOUR, CW_COLOUR, circular_chart, write_circular_report};

use super::model;
use crate::util::tempdir;
use errmap::circular::Slot;
use errmap::circular::{CircularEffect, ServoMismatch};

fn read_png(path: &std::path::Path) -> (usize, usize, Vec<u8>) {
    let decoder = png::Decoder::new(std::fs::File::open(path).expect("png"));
    let mut reader = decoder.read_info().expect("png header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("png frame");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    (info.width as usize, info.height as usize, buf)
}

/// A servo mismatch puts ccw outside cw at 45° and inside at 135° (it turns over with the
/// direction): the PNG holds the ccw colour at the ccw trace's pixel and the cw colour at
/// the cw trace's pixel, at angles where they lie apart, and neither colour far from them.
///
/// The plot removes the centring only: the radius term (the bar's length error, here the
/// model's `bar_error_um`, plus the mean scale, here none) stays in the drawn trace, as it
/// stays in F and in the least-squares circle drawn with it. A trace at a true radial
/// deviation dr is therefore drawn at `bar_error_um + dr`.
#[test]
fn the_polar_plot_draws_each_direction_in_its_colour_where_its_trace_is() {
    let m = model(
        Plane::XY,
        &[(
            CircularEffect::ServoMismatch(ServoMismatch { dt_ms: 3.0 }),
            Slot::Plane,
        )],
        0.0,
        1,
    );
    let radius_term_um = m.bar_error_um;
    let test = simulate(&m).expect("a test within the bounds");
    let d = diagnose(&test, &DiagnoseConfig::default());
    let dir = tempdir();
    write_circular_report(&test, &d, dir.path()).expect("test set-up");
    assert!(dir.path().join("polar.svg").exists());
    let (w, _, px) = read_png(&dir.path().join("polar.png"));
    let at = |(x, y): (i32, i32)| {
        let i = (y as usize * w + x as usize) * 3;
        (px[i], px[i + 1], px[i + 2])
    };
    let near = |c: (u8, u8, u8), want: (u8, u8, u8)| {
        (c.0 as i32 - want.0 as i32).abs() < 40
            && (c.1 as i32 - want.1 as i32).abs() < 40
            && (c.2 as i32 - want.2 as i32).abs() < 40
    };
    let ch = circular_chart(&test, &d);
    let div = ch.um_per_div;
    // v·dt/2 = (2000/60)·3/2 = 50 µm: ccw at +50 µm·sin 2θ, cw at −50 µm·sin 2θ.
    for deg in [45.0f64, 135.0, 225.0, 315.0] {
        let th = deg.to_radians();
        let amp = 50.0 * (2.0 * th).sin();
        let (ccw_um, cw_um) = (radius_term_um + amp, radius_term_um - amp);
        let ccw = at(pixel(th, ccw_um, div));
        let cw = at(pixel(th, cw_um, div));
        assert!(near(ccw, colour(CCW_COLOUR)), "{deg}°: ccw pixel {ccw:?}");
        assert!(near(cw, colour(CW_COLOUR)), "{deg}°: cw pixel {cw:?}");
        // Half a division beyond each trace (away from the other) is not a trace colour.
        for (dr, away) in [(ccw_um, amp.signum()), (cw_um, -amp.signum())] {
            let off = at(pixel(th, dr + away * div * 0.5, div));
            assert!(
                !near(off, colour(CCW_COLOUR)) && !near(off, colour(CW_COLOUR)),
                "{deg}°: {off:?} half a division beyond a trace"
            );
        }
    }
}
