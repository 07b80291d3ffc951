//! Fuzz targets for the renderer's parsers (issue 9): the scene TOML, OBJ geometry
//! (through the scene loader), IES LM-63 and EULUMDAT.
//!
//! No nightly toolchain, so no cargo-fuzz: each target starts from the corpus kept in
//! `fuzz/corpus/<parser>/` (every file first as it is) and then runs proptest-made
//! mutations of it (byte flips, truncation, line duplication and deletion, numbers
//! replaced by extremes such as 1e308, -0, NaN, 4294967296 and huge counts) for
//! `LUMIWALL_FUZZ_SECONDS` seconds (default 5; CI runs them longer). The seed is
//! random and printed; `LUMIWALL_FUZZ_SEED` (a decimal u64) replays a run.
//!
//! Every case must return within [`PER_CASE_LIMIT`] without panicking, with either a
//! typed error or a result whose every float is finite (and within the documented
//! ceilings). A failing input is written to `target/fuzz-failures/` and named in the
//! panic message; add it to the corpus once the parser is fixed.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use lumiwall_render::photometry::IntensityDistribution;
use lumiwall_render::scene::{
    LightKind, MAX_INTENSITY_CD, MAX_LUMINANCE_CD_M2, Scene, V3, parse_scene_toml,
};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// Longest one parser call may take (debug build, shared CI machine).
const PER_CASE_LIMIT: Duration = Duration::from_secs(5);

/// Default run time of one target when `LUMIWALL_FUZZ_SECONDS` is not set.
const DEFAULT_FUZZ_SECONDS: f64 = 5.0;

/// Numbers a mutation puts in place of a number of the input.
const EXTREMES: &[&str] = &[
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "-0",
    "0",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "4294967296",
    "18446744073709551616",
    "9223372036854775807",
    "-1",
    "1e-320",
    "100000",
    "3601",
    "1801",
    "99999999999",
    "0.5",
];

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn corpus_dir(name: &str) -> PathBuf {
    repo_root().join("fuzz/corpus").join(name)
}

fn corpus(name: &str) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(corpus_dir(name))
        .unwrap_or_else(|e| panic!("fuzz/corpus/{name} must exist: {e}"))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "fuzz/corpus/{name} is empty");
    files
        .into_iter()
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect()
}

fn fuzz_budget() -> Duration {
    let s = std::env::var("LUMIWALL_FUZZ_SECONDS")
        .ok()
        .map(|v| {
            v.parse::<f64>()
                .ok()
                .filter(|s| s.is_finite() && *s >= 0.0)
                .unwrap_or_else(|| panic!("LUMIWALL_FUZZ_SECONDS={v:?} is not a number of seconds"))
        })
        .unwrap_or(DEFAULT_FUZZ_SECONDS);
    Duration::from_secs_f64(s)
}

fn fuzz_seed() -> u64 {
    match std::env::var("LUMIWALL_FUZZ_SEED") {
        Ok(v) => v
            .parse()
            .unwrap_or_else(|_| panic!("LUMIWALL_FUZZ_SEED={v:?} is not a u64")),
        Err(_) => std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos() as u64)
            .unwrap_or(0),
    }
}

/// One change to an input.
#[derive(Debug, Clone)]
enum Mutation {
    FlipBit { at: usize, bit: u8 },
    SetByte { at: usize, byte: u8 },
    Truncate { at: usize },
    DuplicateLine { line: usize, times: usize },
    DeleteLine { line: usize },
    SwapLines { a: usize, b: usize },
    ReplaceNumber { nth: usize, with: usize },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(at, bit)| Mutation::FlipBit { at, bit }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Mutation::SetByte { at, byte }),
        any::<usize>().prop_map(|at| Mutation::Truncate { at }),
        (any::<usize>(), 1usize..50)
            .prop_map(|(line, times)| Mutation::DuplicateLine { line, times }),
        any::<usize>().prop_map(|line| Mutation::DeleteLine { line }),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines { a, b }),
        (any::<usize>(), 0..EXTREMES.len())
            .prop_map(|(nth, with)| Mutation::ReplaceNumber { nth, with }),
        (any::<usize>(), 0..EXTREMES.len())
            .prop_map(|(nth, with)| Mutation::ReplaceNumber { nth, with }),
    ]
}

/// (index of the corpus file, mutations applied in order)
fn case(corpus_len: usize) -> impl Strategy<Value = (usize, Vec<Mutation>)> {
    (0..corpus_len, prop::collection::vec(mutation(), 1..6))
}

fn split_lines(b: &[u8]) -> Vec<Vec<u8>> {
    b.split(|c| *c == b'\n').map(<[u8]>::to_vec).collect()
}

fn join_lines(lines: &[Vec<u8>]) -> Vec<u8> {
    lines.join(&b'\n')
}

/// Byte ranges of the numbers in `b` (runs of digits with sign, point, exponent).
fn numbers(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() {
            let mut s = i;
            while s > 0 && matches!(b[s - 1], b'-' | b'+' | b'.') {
                s -= 1;
            }
            let mut e = i;
            while e < b.len() {
                let part = b[e].is_ascii_digit() || matches!(b[e], b'.' | b'e' | b'E');
                let exp_sign = matches!(b[e], b'-' | b'+') && matches!(b[e - 1], b'e' | b'E');
                if !(part || exp_sign) {
                    break;
                }
                e += 1;
            }
            out.push((s, e));
            i = e;
        } else {
            i += 1;
        }
    }
    out
}

fn mutate(mut b: Vec<u8>, muts: &[Mutation]) -> Vec<u8> {
    for m in muts {
        match *m {
            Mutation::FlipBit { at, bit } if !b.is_empty() => {
                let n = b.len();
                b[at % n] ^= 1 << bit;
            }
            Mutation::SetByte { at, byte } if !b.is_empty() => {
                let n = b.len();
                b[at % n] = byte;
            }
            Mutation::Truncate { at } => {
                let n = b.len() + 1;
                b.truncate(at % n);
            }
            Mutation::DuplicateLine { line, times } => {
                let mut lines = split_lines(&b);
                let k = line % lines.len();
                let l = lines[k].clone();
                for _ in 0..times {
                    lines.insert(k, l.clone());
                }
                b = join_lines(&lines);
            }
            Mutation::DeleteLine { line } => {
                let mut lines = split_lines(&b);
                let n = lines.len();
                lines.remove(line % n);
                b = join_lines(&lines);
            }
            Mutation::SwapLines { a, b: c } => {
                let mut lines = split_lines(&b);
                let n = lines.len();
                lines.swap(a % n, c % n);
                b = join_lines(&lines);
            }
            Mutation::ReplaceNumber { nth, with } => {
                let nums = numbers(&b);
                if !nums.is_empty() {
                    let (s, e) = nums[nth % nums.len()];
                    b.splice(s..e, EXTREMES[with].bytes());
                }
            }
            _ => {}
        }
    }
    b
}

/// Runs `check` on every corpus file of `target`, then on mutations of them until
/// the time budget is spent. `check` returns Err(why) when a result is not valid.
fn fuzz(target: &str, mut check: impl FnMut(&[u8]) -> Result<(), String>) {
    let files = corpus(target);
    let budget = fuzz_budget();
    let seed = fuzz_seed();
    let fail = |input: &[u8], why: String| -> ! {
        let dir = repo_root().join("target/fuzz-failures");
        let _ = std::fs::create_dir_all(&dir);
        let path = dir.join(format!("{target}-{seed}"));
        let _ = std::fs::write(&path, input);
        panic!(
            "fuzz target `{target}` (LUMIWALL_FUZZ_SEED={seed}) failed: {why}\ninput written to {}",
            path.display()
        );
    };
    let mut run_one = |input: &[u8]| {
        let start = Instant::now();
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(input)));
        let took = start.elapsed();
        match outcome {
            Err(_) => fail(input, "the parser panicked".into()),
            Ok(Err(why)) => fail(input, why),
            Ok(Ok(())) if took > PER_CASE_LIMIT => fail(
                input,
                format!("one case took {took:?}, more than {PER_CASE_LIMIT:?}"),
            ),
            Ok(Ok(())) => {}
        }
    };
    for (_, bytes) in &files {
        run_one(bytes);
    }
    let mut seed_bytes = [0u8; 32];
    seed_bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &seed_bytes),
    );
    let strategy = case(files.len());
    let start = Instant::now();
    let mut cases = 0u64;
    while start.elapsed() < budget {
        let (k, muts) = strategy.new_tree(&mut runner).unwrap().current();
        let input = mutate(files[k].1.clone(), &muts);
        run_one(&input);
        cases += 1;
    }
    eprintln!(
        "fuzz `{target}`: {} corpus files, {cases} mutated cases in {:?} (LUMIWALL_FUZZ_SEED={seed})",
        files.len(),
        start.elapsed()
    );
}

fn finite3(v: &V3) -> bool {
    v.iter().all(|c| c.is_finite())
}

/// Directions to probe distributions and lights with.
fn probe_directions() -> Vec<[f64; 3]> {
    let mut d = Vec::new();
    for i in 0..7 {
        for j in 0..12 {
            let g = std::f64::consts::PI * i as f64 / 6.0;
            let c = std::f64::consts::TAU * j as f64 / 12.0;
            d.push([g.sin() * c.cos(), g.sin() * c.sin(), -g.cos()]);
        }
    }
    d
}

/// Every float of a loaded scene is finite and within the documented ceilings.
fn validate_scene(s: &Scene) -> Result<(), String> {
    if s.polygons.is_empty() {
        return Err("a scene without polygons was accepted".into());
    }
    for p in &s.polygons {
        if p.vertices.len() < 3 || !p.vertices.iter().all(finite3) {
            return Err(format!(
                "polygon of `{}` is not finite or degenerate",
                p.object
            ));
        }
        if p.material >= s.materials.len() {
            return Err(format!("polygon of `{}` has no material", p.object));
        }
    }
    for m in &s.materials {
        if !m.reflectance_xyz.iter().all(|r| (0.0..1.0).contains(r)) {
            return Err(format!(
                "material `{}` reflectance {:?}",
                m.name, m.reflectance_xyz
            ));
        }
        if !m.emission_cd_m2.iter().all(|e| e.is_finite() && *e >= 0.0)
            || m.emission_cd_m2[1] > MAX_LUMINANCE_CD_M2
        {
            return Err(format!(
                "material `{}` emission {:?}",
                m.name, m.emission_cd_m2
            ));
        }
    }
    for l in &s.lights {
        if !finite3(&l.position) || !l.color_xyz.iter().all(|c| c.is_finite()) {
            return Err(format!("light `{}` position or colour not finite", l.name));
        }
        if let LightKind::Spot { axis, .. } = &l.kind
            && !(finite3(axis) && (axis.norm() - 1.0).abs() < 1e-9)
        {
            return Err(format!("spot `{}` axis {axis:?}", l.name));
        }
        let flux = l.total_flux_lm();
        if !(flux.is_finite() && flux >= 0.0) {
            return Err(format!("light `{}` flux {flux}", l.name));
        }
        for d in probe_directions() {
            let i = l.intensity_cd(&V3::new(d[0], d[1], d[2]));
            if !(i.is_finite() && (0.0..=MAX_INTENSITY_CD * (1.0 + 1e-9)).contains(&i)) {
                return Err(format!("light `{}` intensity {i} towards {d:?}", l.name));
            }
        }
    }
    if let Some(c) = &s.camera {
        let fwd = c.look_at - c.position;
        if !(finite3(&c.position) && finite3(&c.look_at) && finite3(&c.up))
            || fwd.norm() <= 0.0
            || fwd.normalize().cross(&c.up.normalize()).norm() <= 0.0
            || !(c.vfov_deg > 0.0 && c.vfov_deg < 180.0)
            || u64::from(c.width_px) * u64::from(c.height_px)
                > lumiwall_render::scene::MAX_CAMERA_PIXELS
        {
            return Err(format!("camera {c:?}"));
        }
    }
    if let Some(sky) = &s.sky {
        for src in sky.sources() {
            if !(finite3(&src.direction)
                && src.normal_illuminance_lux.is_finite()
                && src.color_xyz.iter().all(|c| c.is_finite()))
            {
                return Err(format!("sky source {src:?}"));
            }
        }
    }
    let phi = s.emitted_flux_xyz_lm();
    if !phi.iter().all(|f| f.is_finite()) {
        return Err(format!("emitted flux {phi:?}"));
    }
    Ok(())
}

/// Every float a distribution reports is finite and within the ceilings.
fn validate_distribution(d: &IntensityDistribution) -> Result<(), String> {
    let flux = d.total_flux_lm();
    let peak = d.max_intensity_cd();
    if !(flux.is_finite() && flux >= 0.0) {
        return Err(format!("total flux {flux}"));
    }
    if !(peak.is_finite() && (0.0..=MAX_INTENSITY_CD).contains(&peak)) {
        return Err(format!("peak intensity {peak}"));
    }
    for f in [d.declared_flux_lm(), d.rated_lamp_flux_lm()]
        .into_iter()
        .flatten()
    {
        if !f.is_finite() {
            return Err(format!("declared/rated flux {f}"));
        }
    }
    for dir in probe_directions() {
        let i = d.intensity_cd(dir);
        if !(i.is_finite() && i >= 0.0 && i <= peak * (1.0 + 1e-9) + 1e-300) {
            return Err(format!("intensity {i} towards {dir:?} (peak {peak})"));
        }
    }
    Ok(())
}

#[test]
fn fuzz_scene_toml_parser_never_panics_and_accepts_only_finite_scenes() {
    let base = corpus_dir("scene");
    fuzz("scene", |input| {
        let text = String::from_utf8_lossy(input);
        match parse_scene_toml(&text, &base, Path::new("fuzz.toml")) {
            Ok((scene, _)) => validate_scene(&scene),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }
    });
}

#[test]
fn fuzz_obj_geometry_through_the_scene_loader_never_panics_and_accepts_only_finite_scenes() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("fuzz.obj");
    let toml = "geometry = \"fuzz.obj\"\ndefault_material = \"white\"\n\
                [materials.white]\nreflectance_y = 0.5\nemission_cd_m2 = 10\n";
    fuzz("obj", |input| {
        std::fs::write(&obj, input).map_err(|e| e.to_string())?;
        match parse_scene_toml(toml, dir.path(), Path::new("fuzz.toml")) {
            Ok((scene, _)) => validate_scene(&scene),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }
    });
}

#[test]
fn fuzz_ies_parser_never_panics_and_accepts_only_finite_distributions() {
    fuzz("ies", |input| {
        match IntensityDistribution::from_ies_lm63(&String::from_utf8_lossy(input)) {
            Ok(d) => validate_distribution(&d),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }
    });
}

#[test]
fn fuzz_eulumdat_parser_never_panics_and_accepts_only_finite_distributions() {
    fuzz(
        "eulumdat",
        |input| match IntensityDistribution::from_eulumdat(&String::from_utf8_lossy(input)) {
            Ok(d) => validate_distribution(&d),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        },
    );
}

#[test]
fn mutations_change_the_input_and_replace_numbers_by_extremes() {
    let m = mutate(
        b"a = 12.5e3\nb = -7\n".to_vec(),
        &[Mutation::ReplaceNumber { nth: 1, with: 5 }],
    );
    assert_eq!(m, b"a = 12.5e3\nb = NaN\n");
    let m = mutate(
        b"x\ny".to_vec(),
        &[Mutation::DuplicateLine { line: 1, times: 2 }],
    );
    assert_eq!(m, b"x\ny\ny\ny");
    assert_eq!(numbers(b"v 1e-5 -2 x3"), vec![(2, 6), (7, 9), (11, 12)]);
}
