//! Prints, as JSON on stdout, lumiwall's colorimetry results on fixed inputs, for the
//! colour-science cross-check in `tests/python/test_colorimetry.py`: xyY ↔ XYZ, CIELAB,
//! CIEDE2000 on all 34 Sharma et al. (2005) pairs, CCT → xy and Bradford adaptation.
//!
//! Run: `cargo run -q -p lumiwall-calib --bin colour_dump` (`scripts/test` passes the
//! program `cargo test` built to the Python tests as `LUMIWALL_COLOUR_DUMP`).

use std::path::PathBuf;

use lumiwall_calib::colorimetry::{
    D50_XY, D65_XY, Lab, bradford_adapt, bradford_adaptation_matrix, cct_to_xy, delta_e2000,
    delta_e2000_xyz, xyy_to_xyz, xyz_to_lab, xyz_to_xyy,
};
use lumiwall_devices::Xyz;
use serde_json::{Value, json};

fn sharma_pairs() -> Result<Vec<(u32, Lab, Lab, f64)>, String> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/colour/sharma2005.csv");
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    for line in text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("pair"))
    {
        let f: Vec<f64> = line
            .split(',')
            .map(|s| s.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("{}: bad line {line:?}: {e}", path.display()))?;
        if f.len() != 8 {
            return Err(format!(
                "{}: line {line:?} has {} fields",
                path.display(),
                f.len()
            ));
        }
        out.push((
            f[0] as u32,
            Lab::new(f[1], f[2], f[3]),
            Lab::new(f[4], f[5], f[6]),
            f[7],
        ));
    }
    Ok(out)
}

fn a(v: Xyz) -> [f64; 3] {
    v.to_array()
}

/// XYZ samples (cd/m²) every conversion is dumped for.
const SAMPLES: [Xyz; 6] = [
    Xyz::new(20.654, 12.197, 5.136),
    Xyz::new(95.047, 100.0, 108.883),
    Xyz::new(0.5, 0.55, 0.9),
    Xyz::new(41.2, 21.3, 1.9),
    Xyz::new(14.1, 57.4, 9.6),
    Xyz::new(0.02, 0.01, 0.3),
];

/// xyY → XYZ and back.
fn xyy_dumps() -> (Vec<Value>, Vec<Value>) {
    let xyy: Vec<Value> = SAMPLES
        .iter()
        .map(|s| json!({"xyz": a(*s), "xyy": xyz_to_xyy(*s, D65_XY)}))
        .collect();
    let xyy_in = [
        [0.3127, 0.329, 80.0],
        [0.64, 0.33, 17.0],
        [0.15, 0.06, 0.4],
        [0.29, 0.6, 250.0],
    ];
    let xyz_from: Vec<Value> = xyy_in
        .iter()
        .map(|v| json!({"xyy": v, "xyz": a(xyy_to_xyz(*v))}))
        .collect();
    (xyy, xyz_from)
}

/// CIELAB of the samples, the white and a dark colour, against a D65 and an 8500 K white.
fn lab_dump(white_d65: Xyz, w8500: [f64; 2]) -> Vec<Value> {
    let white_8500 = Xyz::from_xy_luminance(w8500[0], w8500[1], 77.86);
    let mut lab = Vec::new();
    for white in [white_d65, white_8500] {
        for s in SAMPLES
            .iter()
            .chain([white, Xyz::new(0.05, 0.04, 0.06)].iter())
        {
            let l = xyz_to_lab(*s, white);
            lab.push(json!({"xyz": a(*s), "white": a(white), "lab": [l.l, l.a, l.b]}));
        }
    }
    lab
}

/// ΔE2000 between neighbouring samples, and of the Sharma pairs.
fn delta_e_dumps(white_d65: Xyz) -> Result<(Vec<Value>, Vec<Value>), String> {
    let de_xyz: Vec<Value> = SAMPLES
        .windows(2)
        .map(|w| {
            json!({"target": a(w[0]), "measured": a(w[1]), "white": a(white_d65),
                   "delta_e": delta_e2000_xyz(w[0], w[1], white_d65)})
        })
        .collect();
    let sharma: Vec<Value> = sharma_pairs()?
        .into_iter()
        .map(|(pair, l1, l2, published)| {
            json!({"pair": pair, "lab1": [l1.l, l1.a, l1.b], "lab2": [l2.l, l2.a, l2.b],
                   "published": published, "delta_e": delta_e2000(l1, l2)})
        })
        .collect();
    Ok((de_xyz, sharma))
}

/// Daylight-locus chromaticities of a few colour temperatures.
fn cct_dump() -> Result<Vec<Value>, String> {
    let mut cct = Vec::new();
    for k in [
        4000.0, 5003.0, 6500.0, 6504.0, 7000.0, 8500.0, 10000.0, 25000.0,
    ] {
        cct.push(json!({"kelvin": k, "xy": cct_to_xy(k).map_err(|e| e.to_string())?}));
    }
    Ok(cct)
}

/// Bradford adaptation matrices and adapted samples between D65, D50 and 8500 K.
fn bradford_dump(w8500: [f64; 2]) -> Result<Vec<Value>, String> {
    let d65 = Xyz::from_xy_luminance(D65_XY[0], D65_XY[1], 1.0);
    let d50 = Xyz::from_xy_luminance(D50_XY[0], D50_XY[1], 1.0);
    let w85 = Xyz::from_xy_luminance(w8500[0], w8500[1], 1.0);
    let mut bradford = Vec::new();
    for (src, dst) in [(d65, d50), (d65, w85), (w85, d65)] {
        let m = bradford_adaptation_matrix(src, dst).ok_or("degenerate white")?;
        let rows: Vec<[f64; 3]> = (0..3).map(|r| [m[(r, 0)], m[(r, 1)], m[(r, 2)]]).collect();
        for s in &SAMPLES {
            bradford.push(
                json!({"xyz": a(*s), "src_white": a(src), "dst_white": a(dst),
                                 "adapted": a(bradford_adapt(*s, src, dst)), "matrix": rows}),
            );
        }
    }
    Ok(bradford)
}

fn main() -> Result<(), String> {
    let (xyy, xyz_from) = xyy_dumps();
    let white_d65 = Xyz::from_xy_luminance(D65_XY[0], D65_XY[1], 80.0);
    let w8500 = cct_to_xy(8500.0).map_err(|e| e.to_string())?;
    let lab = lab_dump(white_d65, w8500);
    let (de_xyz, sharma) = delta_e_dumps(white_d65)?;
    let cct = cct_dump()?;
    let bradford = bradford_dump(w8500)?;
    let out = json!({
        "xyz_to_xyy": xyy, "xyy_to_xyz": xyz_from, "lab": lab, "delta_e2000_xyz": de_xyz,
        "sharma": sharma, "cct_to_xy": cct, "bradford": bradford,
    });
    println!(
        "{}",
        serde_json::to_string_pretty(&out).map_err(|e| e.to_string())?
    );
    Ok(())
}
