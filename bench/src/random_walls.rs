//! Walls of issue 12's classes drawn at random, for `lumiwall bench random-walls`: the
//! station is judged on walls nobody chose, not on the fixtures it was tuned on.
//!
//! Wall `n` is drawn from a generator seeded with `n` alone (ChaCha8, so the same wall
//! on every machine as long as the locked `rand` versions stay), and its file is
//! written out: a wall that fails can be run again with `bench readings --wall`. Each draw mixes the
//! classes of issue 12 within the ranges real projection walls show:
//! - mono or Infitec stereo (a third), 1–3 × 1–2 tiles (at most 3 on Infitec);
//! - 8-, 10- or 12-bit inputs; UHP or xenon lamps of 5500–9000 K;
//! - the lamp's white 40–3000 cd/m² (log-uniform), so wall whites from a few cd/m² up;
//! - single-chip DLPs with a white segment of 0.08–0.5 on half the walls, and on a fifth
//!   of the others one display with a segment of 0.1–0.3 (a mixed wall);
//! - tone curves unlike the defaults on three in five (γ 1.8–2.8, S-shape, shoulder);
//! - a cold start (0.5–5 minutes after switch-on, lamps settling in 2–10 minutes) on a
//!   quarter; a gain screen on two in five and an off-axis tripod on three in ten;
//! - black leaks of 0.02–0.6 % of the lamp, vignetting and hot spots;
//! - one display with a channel at 8–30 % on two in five (a weak channel).
//!
//! Ranges of the generator are the class; the seed of each drawn wall's scatter is drawn
//! too.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt::Write;

/// One drawn wall.
#[derive(Debug, Clone, PartialEq)]
pub struct RandomWall {
    /// Its number (the generator's seed).
    pub index: u64,
    /// The wall file (TOML, the format of `fixtures/walls/README.md`).
    pub toml: String,
    /// Whether any display has a white segment (not additive: read with the
    /// non-additive budget).
    pub non_additive: bool,
    /// A short description of what was drawn.
    pub summary: String,
}

/// What was drawn for a wall, before it is written out.
struct Draw {
    infitec: bool,
    tiles: [u32; 2],
    bit_depth: u32,
    white_segment: f64,
    cold_minutes: Option<f64>,
    weak: Option<(u32, usize, f64)>,
    mixed_segment: Option<(u32, f64)>,
    off_axis: bool,
    gain_screen: bool,
    lamp_white_cd_m2: f64,
}

/// Wall `index` of the class (module docs).
pub fn random_wall(index: u64) -> RandomWall {
    let mut rng = ChaCha8Rng::seed_from_u64(index);
    let mut toml = String::new();
    let d = draw(&mut rng);
    write_header(&mut toml, &mut rng, index, &d);
    write_projector(&mut toml, &mut rng, &d);
    write_overrides(&mut toml, &d);
    if d.infitec {
        write_infitec(&mut toml, &mut rng);
    }
    RandomWall {
        index,
        toml,
        non_additive: d.white_segment > 0.0 || d.mixed_segment.is_some(),
        summary: summary(&d),
    }
}

/// Draws the wall's class parameters.
fn draw(rng: &mut ChaCha8Rng) -> Draw {
    let infitec = rng.random_bool(1.0 / 3.0);
    let cols = rng.random_range(1..=3);
    let rows = if infitec && cols > 1 {
        1
    } else {
        rng.random_range(1..=2)
    };
    let displays = cols * rows * if infitec { 2 } else { 1 };
    let white_segment = if rng.random_bool(0.5) {
        0.0
    } else {
        rng.random_range(0.08..0.5)
    };
    let mixed_segment = (white_segment == 0.0 && rng.random_bool(0.2))
        .then(|| (rng.random_range(0..displays), rng.random_range(0.1..0.3)));
    Draw {
        infitec,
        tiles: [cols, rows],
        bit_depth: [8, 8, 10, 10, 12][rng.random_range(0..5)],
        white_segment,
        cold_minutes: rng.random_bool(0.25).then(|| rng.random_range(0.5..5.0)),
        weak: rng.random_bool(0.4).then(|| {
            (
                rng.random_range(0..displays),
                rng.random_range(0..3),
                rng.random_range(0.08..0.3),
            )
        }),
        mixed_segment,
        off_axis: rng.random_bool(0.3),
        gain_screen: rng.random_bool(0.4),
        lamp_white_cd_m2: rng.random_range(40f64.ln()..3000f64.ln()).exp(),
    }
}

/// Name, seed, tiles, clock, screen and meter.
fn write_header(t: &mut String, rng: &mut ChaCha8Rng, index: u64, d: &Draw) {
    let stereo = if d.infitec { "infitec" } else { "mono" };
    let [cols, rows] = d.tiles;
    let _ = writeln!(t, "name = \"random-{index}\"");
    let _ = writeln!(t, "seed = {}", rng.random_range(1..1_000_000u64));
    let _ = writeln!(t, "stereo = \"{stereo}\"");
    let _ = writeln!(t, "description = \"{}\"", summary(d));
    let (w, h) = (rng.random_range(1.2..3.0), rng.random_range(0.9..2.2));
    let _ = writeln!(
        t,
        "[tiles]\ncols = {cols}\nrows = {rows}\nwidth_m = {w:.2}\nheight_m = {h:.2}"
    );
    let minutes = d.cold_minutes.unwrap_or(30.0);
    let _ = writeln!(
        t,
        "[clock]\nseconds_per_reading = 1.0\nminutes_since_switch_on = {minutes:.2}"
    );
    let specular = if d.gain_screen {
        rng.random_range(0.1..0.45)
    } else {
        0.0
    };
    let width = rng.random_range(10.0..20.0);
    let _ = writeln!(
        t,
        "[screen]\ndiffuse_gain = 1.0\nspecular_gain = {specular:.3}\nspecular_width_deg = {width:.1}"
    );
    if d.off_axis {
        let x = rng.random_range(0.0..f64::from(cols) * w);
        let (y, z) = (rng.random_range(0.0..1.0), rng.random_range(2.0..4.0));
        let _ = writeln!(t, "[meter]\nposition_m = [{x:.2}, {y:.2}, {z:.2}]");
    }
}

/// The projector model: lamp, curves, warm-up, black, falloff and scatter.
fn write_projector(t: &mut String, rng: &mut ChaCha8Rng, d: &Draw) {
    // Lamp hours are drawn per projector by the scatter (100–1500 h).
    let throw = rng.random_range(1.4..3.0);
    let _ = writeln!(
        t,
        "[projector]\nmodel = \"drawn\"\nbit_depth = {}\nthrow_m = {throw:.2}\nwhite_segment = {:.3}",
        d.bit_depth, d.white_segment
    );
    let kind = if rng.random_bool(0.5) { "uhp" } else { "xenon" };
    let cct = rng.random_range(5500.0..9000.0);
    let _ = writeln!(
        t,
        "[projector.lamp]\nkind = \"{kind}\"\ncct_k = {cct:.0}\nwhite_cd_m2 = {:.1}",
        d.lamp_white_cd_m2
    );
    if rng.random_bool(0.6) {
        t.push_str("[projector.curves]\n");
        for channel in ["red", "green", "blue"] {
            let _ = writeln!(
                t,
                "{channel} = {{ gamma = {:.2}, s_weight = {:.2}, s_centre = {:.2}, s_steepness = {:.1}, shoulder = {:.2} }}",
                rng.random_range(1.8..2.8),
                rng.random_range(0.0..0.45),
                rng.random_range(0.4..0.65),
                rng.random_range(6.0..12.0),
                rng.random_range(0.5..2.5)
            );
        }
    }
    if d.cold_minutes.is_some() {
        let deficit: [f64; 3] = std::array::from_fn(|_| rng.random_range(0.03..0.15));
        let _ = writeln!(
            t,
            "[projector.warmup]\ndeficit = {}\nminutes = {:.1}",
            triple(deficit, 3),
            rng.random_range(2.0..10.0)
        );
    }
    let leak: [f64; 3] = std::array::from_fn(|_| rng.random_range(0.0002..0.006));
    let _ = writeln!(
        t,
        "[projector.black]\nleak = {}\nstray = {:.5}",
        triple(leak, 5),
        rng.random_range(0.0..0.0005)
    );
    let v: [f64; 3] = std::array::from_fn(|_| rng.random_range(0.1..0.45));
    let _ = writeln!(
        t,
        "[projector.falloff]\nvignetting = {}\nhotspot_gain = {:.3}\nhotspot_sigma = {:.2}\nhotspot_offset = [{:.3}, {:.3}]",
        triple(v, 2),
        rng.random_range(0.0..0.1),
        rng.random_range(0.15..0.35),
        rng.random_range(-0.05..0.05),
        rng.random_range(-0.05..0.05)
    );
    t.push_str(
        "[scatter]\nlamp_power_rel = 0.06\npanel_shift_nm = 1.5\ncomb_shift_nm = 0.8\n\
         channel_gain_rel = 0.05\ngamma = 0.06\ncurve_shape = 0.03\nvignetting_rel = 0.15\n\
         hotspot_offset = 0.04\nlamp_hours = [100.0, 1500.0]\n",
    );
}

/// The weak channel and the one display with a white segment, where drawn.
fn write_overrides(t: &mut String, d: &Draw) {
    if let Some((display, channel, gain)) = d.weak {
        let mut g = [1.0; 3];
        g[channel] = gain;
        let _ = writeln!(
            t,
            "[[override]]\ndisplay = {display}\nchannel_gain = {}",
            triple(g, 3)
        );
    }
    if let Some((display, segment)) = d.mixed_segment {
        let _ = writeln!(
            t,
            "[[override]]\ndisplay = {display}\nwhite_segment = {segment:.3}"
        );
    }
}

/// `[a, b, c]` with `decimals` decimals each (a TOML array of three).
fn triple(v: [f64; 3], decimals: usize) -> String {
    format!(
        "[{:.*}, {:.*}, {:.*}]",
        decimals, v[0], decimals, v[1], decimals, v[2]
    )
}

/// The two eyes' comb filters, shifted together by up to ±2 nm.
fn write_infitec(t: &mut String, rng: &mut ChaCha8Rng) {
    let s = rng.random_range(-2.0..2.0);
    let band = |lo: f64, hi: f64, peak: f64| {
        format!(
            "  {{ lo_nm = {:.1}, hi_nm = {:.1}, edge_nm = 1.5, peak = {peak:.2} }},",
            lo + s,
            hi + s
        )
    };
    let eyes = [
        (
            "left",
            [
                (448.0, 464.0, 0.9),
                (520.0, 532.0, 0.8),
                (604.0, 628.0, 0.9),
            ],
        ),
        (
            "right",
            [
                (462.0, 480.0, 0.9),
                (540.0, 564.0, 0.9),
                (630.0, 646.0, 0.85),
            ],
        ),
    ];
    for (eye, bands) in eyes {
        let _ = writeln!(t, "[infitec.{eye}]\nleak = 0.002\nbands = [");
        for (lo, hi, peak) in bands {
            let _ = writeln!(t, "{}", band(lo, hi, peak));
        }
        t.push_str("]\n");
    }
}

/// "Infitec 3x1, 10-bit, DLP white 0.21, cold 2.3 min, weak blue 12 %, off-axis".
fn summary(d: &Draw) -> String {
    let [cols, rows] = d.tiles;
    let mut s = format!(
        "{} {cols}x{rows}, {}-bit",
        if d.infitec { "Infitec" } else { "mono" },
        d.bit_depth
    );
    if d.white_segment > 0.0 {
        let _ = write!(s, ", DLP white {:.2}", d.white_segment);
    }
    if let Some((display, segment)) = d.mixed_segment {
        let _ = write!(s, ", display {display} DLP white {segment:.2}");
    }
    if let Some(m) = d.cold_minutes {
        let _ = write!(s, ", cold {m:.1} min");
    }
    if let Some((display, channel, gain)) = d.weak {
        let name = ["red", "green", "blue"][channel];
        let _ = write!(s, ", display {display} {name} {:.0} %", 100.0 * gain);
    }
    if d.gain_screen {
        s.push_str(", gain screen");
    }
    if d.off_axis {
        s.push_str(", off-axis");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumiwall_devices::sim::VirtualWall;

    #[test]
    fn every_drawn_wall_loads_and_the_same_number_draws_the_same_wall() {
        let mut non_additive = 0;
        let mut infitec = 0;
        for i in 0..60 {
            let w = random_wall(i);
            assert_eq!(w, random_wall(i));
            let wall = VirtualWall::from_toml_str(&w.toml)
                .unwrap_or_else(|e| panic!("wall {i}: {e}\n{}", w.toml));
            assert!(!wall.displays().is_empty());
            non_additive += usize::from(w.non_additive);
            infitec += usize::from(w.summary.starts_with("Infitec"));
        }
        // the classes are all drawn: about 3/5 non-additive, 1/3 Infitec
        assert!((20..50).contains(&non_additive), "{non_additive}");
        assert!((10..35).contains(&infitec), "{infitec}");
        assert_ne!(random_wall(1).toml, random_wall(2).toml);
    }
}
