//! Corpus-driven mutation fuzzing on top of proptest, shared by the fuzz targets of
//! the workspace's crates (`devices/tests/fuzz_parsers.rs`,
//! `profiles/tests/fuzz_parsers.rs`, `render/tests/fuzz_parsers.rs` include it with
//! `#[path]`).
//!
//! A target starts from the files in `fuzz/corpus/<parser>/` (the fixtures and the
//! interesting cases, crashing inputs found earlier included) and applies a few
//! mutations to one of them: bit flips, byte replacements, truncation, deletion,
//! duplication, splicing with another corpus file, line duplication, deletion and
//! swaps, and numbers replaced by extremes
//! (1e308, -0, NaN, inf, huge integers). Every case runs on a worker thread and must
//! finish within [`case_limit`] (no hang); a panic or a property violation fails the
//! target with the shrunk input, written to `$CARGO_TARGET_TMPDIR` for the corpus.
//!
//! Each target runs for a bounded time: `LUMIWALL_FUZZ_SECONDS` (default 5 s, so the
//! normal test suite stays fast; CI raises it, e.g. to 60). `LUMIWALL_FUZZ_SEED`
//! fixes the seed (default: derived from the clock, printed so a run can be
//! repeated); `LUMIWALL_FUZZ_CASE_SECONDS` bounds one case (default 20 s).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, FileFailurePersistence, RngAlgorithm, TestRng, TestRunner};

/// Time budget of one fuzz target (`LUMIWALL_FUZZ_SECONDS`, default 5 s).
pub(crate) fn budget() -> Duration {
    env_seconds("LUMIWALL_FUZZ_SECONDS", 5.0)
}

/// Longest one case may take before it counts as a hang (`LUMIWALL_FUZZ_CASE_SECONDS`,
/// default 20 s: far above any parser's real time, below a test harness timeout).
pub(crate) fn case_limit() -> Duration {
    env_seconds("LUMIWALL_FUZZ_CASE_SECONDS", 20.0)
}

fn env_seconds(name: &str, default: f64) -> Duration {
    let v = std::env::var(name)
        .ok()
        .and_then(|s| s.trim().parse::<f64>().ok())
        .filter(|v| v.is_finite() && *v >= 0.0 && *v <= 1e6)
        .unwrap_or(default);
    Duration::from_secs_f64(v)
}

fn seed() -> u64 {
    std::env::var("LUMIWALL_FUZZ_SEED")
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos() as u64)
                .unwrap_or(0)
        })
}

/// The files of `fuzz/corpus/<parser>/`, sorted by name, as (name, bytes).
pub(crate) fn corpus(parser: &str) -> Vec<(String, Vec<u8>)> {
    let dir = corpus_dir(parser);
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("corpus folder {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p.file_name().unwrap().to_string_lossy().into_owned(), bytes)
        })
        .collect();
    files.sort();
    assert!(!files.is_empty(), "empty corpus folder {}", dir.display());
    files
}

/// `fuzz/corpus/<parser>` of the workspace.
pub(crate) fn corpus_dir(parser: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fuzz/corpus")
        .join(parser)
}

/// Numbers a field may be replaced by: float and integer extremes.
pub(crate) const EXTREMES: &[&str] = &[
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e309",
    "-0",
    "-0.0",
    "0",
    "0.0",
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "+inf",
    "Infinity",
    "5e-324",
    "1e-320",
    "-1",
    "1",
    "2",
    "255",
    "256",
    "65535",
    "65536",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "340282366920938463463374607431768211456",
    "1e400",
    "0x7fffffff",
    "1_000_000",
    "\"\"",
    "[]",
    "{}",
    "null",
    "true",
];

/// Bytes worth putting into a text: structure characters of TOML/JSON, controls,
/// the protocol's framing, and bytes that are not UTF-8.
const INTERESTING_BYTES: &[u8] = &[
    0, b'\n', b'\r', b'\t', b' ', b'"', b'\'', b'\\', b'[', b']', b'{', b'}', b',', b':', b'=',
    b'.', b'-', b'+', b'e', b'#', b'<', b'>', b'0', b'9', 0x7f, 0x80, 0xc3, 0xff,
];

/// One mutation of a byte string.
#[derive(Debug, Clone)]
pub(crate) enum Mutation {
    /// Flip one bit of one byte.
    FlipBit(Index, u8),
    /// Replace one byte with an interesting or random one.
    SetByte(Index, u8),
    /// Cut the input at a position.
    Truncate(Index),
    /// Remove a range.
    Delete(Index, usize),
    /// Repeat a range right after itself.
    Duplicate(Index, usize),
    /// Insert a range of another corpus file at a position.
    Splice(Index, Index, Index, usize),
    /// Replace the n-th number in the input by an extreme.
    Number(Index, &'static str),
    /// Insert an extreme at a position.
    InsertText(Index, &'static str),
    /// Repeat line `n` (modulo the line count) this many times.
    DuplicateLine(usize, usize),
    /// Remove line `n` (modulo the line count).
    DeleteLine(usize),
    /// Swap two lines (each modulo the line count).
    SwapLines(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let byte = prop_oneof![prop::sample::select(INTERESTING_BYTES), any::<u8>()];
    let extreme = prop::sample::select(EXTREMES);
    prop_oneof![
        (any::<Index>(), 0u8..8).prop_map(|(i, b)| Mutation::FlipBit(i, b)),
        (any::<Index>(), byte).prop_map(|(i, b)| Mutation::SetByte(i, b)),
        any::<Index>().prop_map(Mutation::Truncate),
        (any::<Index>(), 1usize..64).prop_map(|(i, n)| Mutation::Delete(i, n)),
        (any::<Index>(), 1usize..256).prop_map(|(i, n)| Mutation::Duplicate(i, n)),
        (any::<Index>(), any::<Index>(), any::<Index>(), 1usize..512)
            .prop_map(|(a, f, b, n)| Mutation::Splice(a, f, b, n)),
        (any::<Index>(), extreme.clone()).prop_map(|(i, e)| Mutation::Number(i, e)),
        (any::<Index>(), extreme).prop_map(|(i, e)| Mutation::InsertText(i, e)),
        (any::<usize>(), 1usize..50).prop_map(|(l, n)| Mutation::DuplicateLine(l, n)),
        any::<usize>().prop_map(Mutation::DeleteLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
    ]
}

/// Applies a change to the lines of `data` (split at `\n`; never empty).
fn edit_lines(data: &mut Vec<u8>, edit: impl FnOnce(&mut Vec<Vec<u8>>)) {
    let mut lines: Vec<Vec<u8>> = data.split(|c| *c == b'\n').map(<[u8]>::to_vec).collect();
    edit(&mut lines);
    *data = lines.join(&b'\n');
}

/// Byte ranges of the numbers in `s`: maximal runs of digits with their sign,
/// point, exponent and underscores.
pub(crate) fn numbers(s: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < s.len() {
        if s[i].is_ascii_digit() {
            let mut start = i;
            if start > 0 && matches!(s[start - 1], b'-' | b'+') {
                start -= 1;
            }
            let mut end = i;
            while end < s.len()
                && (s[end].is_ascii_digit() || matches!(s[end], b'.' | b'e' | b'E' | b'_'))
            {
                end += 1;
                if end < s.len()
                    && matches!(s[end - 1], b'e' | b'E')
                    && matches!(s[end], b'-' | b'+')
                {
                    end += 1;
                }
            }
            out.push((start, end));
            i = end;
        } else {
            i += 1;
        }
    }
    out
}

/// Applies `m` to `data`; `corpus` is the pool splices take from.
pub(crate) fn apply(data: &mut Vec<u8>, m: &Mutation, corpus: &[(String, Vec<u8>)]) {
    let at = |i: &Index, len: usize| if len == 0 { 0 } else { i.index(len) };
    match m {
        Mutation::FlipBit(i, b) => {
            if !data.is_empty() {
                let k = at(i, data.len());
                data[k] ^= 1 << b;
            }
        }
        Mutation::SetByte(i, b) => {
            if !data.is_empty() {
                let k = at(i, data.len());
                data[k] = *b;
            }
        }
        Mutation::Truncate(i) => {
            let k = at(i, data.len() + 1);
            data.truncate(k);
        }
        Mutation::Delete(i, n) => {
            let k = at(i, data.len() + 1);
            let end = (k + n).min(data.len());
            data.drain(k..end);
        }
        Mutation::Duplicate(i, n) => {
            let k = at(i, data.len() + 1);
            let end = (k + n).min(data.len());
            let chunk = data[k..end].to_vec();
            data.splice(end..end, chunk);
        }
        Mutation::Splice(a, f, b, n) => {
            let other = &corpus[at(f, corpus.len())].1;
            let from = at(b, other.len() + 1);
            let chunk = &other[from..(from + n).min(other.len())];
            let k = at(a, data.len() + 1);
            data.splice(k..k, chunk.iter().copied());
        }
        Mutation::Number(i, e) => {
            let nums = numbers(data);
            if !nums.is_empty() {
                let (s, t) = nums[at(i, nums.len())];
                data.splice(s..t, e.bytes());
            }
        }
        Mutation::InsertText(i, e) => {
            let k = at(i, data.len() + 1);
            data.splice(k..k, e.bytes());
        }
        Mutation::DuplicateLine(line, times) => edit_lines(data, |lines| {
            let k = line % lines.len();
            let copies = vec![lines[k].clone(); *times];
            lines.splice(k..k, copies);
        }),
        Mutation::DeleteLine(line) => edit_lines(data, |lines| {
            let n = lines.len();
            lines.remove(line % n);
        }),
        Mutation::SwapLines(a, b) => edit_lines(data, |lines| {
            let n = lines.len();
            lines.swap(a % n, b % n);
        }),
    }
}

/// A corpus file and the mutations applied to it (none: the file as it is).
pub(crate) fn case(corpus_len: usize) -> impl Strategy<Value = (usize, Vec<Mutation>)> {
    (
        0..corpus_len,
        prop_oneof![
            1 => Just(Vec::new()),
            9 => prop::collection::vec(mutation(), 1..6),
        ],
    )
}

/// The bytes of a case.
pub(crate) fn build(
    corpus: &[(String, Vec<u8>)],
    (file, mutations): &(usize, Vec<Mutation>),
) -> Vec<u8> {
    let mut data = corpus[*file].1.clone();
    for m in mutations {
        apply(&mut data, m, corpus);
    }
    data
}

/// Runs `check` on `input` on a worker thread, failing when it panics or takes
/// longer than `limit`.
fn bounded<F>(check: &Arc<F>, input: Vec<u8>, limit: Duration) -> Result<(), String>
where
    F: Fn(&[u8]) -> Result<(), String> + Send + Sync + 'static,
{
    let (tx, rx) = mpsc::channel();
    let check = Arc::clone(check);
    let worker = std::thread::Builder::new()
        .name("fuzz-case".into())
        .spawn(move || {
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(&input)));
            let _ = tx.send(outcome);
        })
        .map_err(|e| format!("cannot start the case thread: {e}"))?;
    match rx.recv_timeout(limit) {
        Ok(Ok(result)) => {
            let _ = worker.join();
            result
        }
        Ok(Err(panic)) => {
            let _ = worker.join();
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "non-text panic".into());
            Err(format!("panicked: {msg}"))
        }
        // The worker is left running: a hang cannot be interrupted, only reported.
        Err(_) => Err(format!("did not finish within {limit:?} (hang)")),
    }
}

/// Fuzzes `check` for [`budget`] with mutations of the corpus `parser`; `check`
/// returns `Err` for a property violation. Returns the number of cases run.
pub(crate) fn fuzz<F>(parser: &str, check: F) -> u64
where
    F: Fn(&[u8]) -> Result<(), String> + Send + Sync + 'static,
{
    let corpus = Arc::new(corpus(parser));
    let check = Arc::new(check);
    let limit = case_limit();
    // Every corpus file as it is, first.
    for (name, bytes) in corpus.iter() {
        if let Err(e) = bounded(&check, bytes.clone(), limit) {
            panic!("fuzz target {parser}: corpus file {name} fails: {e}");
        }
    }
    let budget = budget();
    let seed = seed();
    eprintln!(
        "fuzz target {parser}: {} corpus files, {budget:?}, LUMIWALL_FUZZ_SEED={seed}",
        corpus.len()
    );
    let start = Instant::now();
    let mut cases = corpus.len() as u64;
    let mut batch = 0u64;
    while start.elapsed() < budget {
        let mut bytes = [0u8; 32];
        bytes[..8].copy_from_slice(&seed.to_le_bytes());
        bytes[8..16].copy_from_slice(&batch.to_le_bytes());
        let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &bytes);
        let config = Config {
            cases: 32,
            failure_persistence: Some(Box::new(FileFailurePersistence::Off)),
            max_shrink_time: 30_000,
            ..Config::default()
        };
        let mut runner = TestRunner::new_with_rng(config, rng);
        let (c, k) = (Arc::clone(&corpus), Arc::clone(&check));
        let result = runner.run(&case(corpus.len()), move |m| {
            let input = build(&c, &m);
            bounded(&k, input, limit).map_err(TestCaseError::fail)
        });
        if let Err(e) = result {
            let detail = match &e {
                proptest::test_runner::TestError::Fail(reason, m) => {
                    let input = build(&corpus, m);
                    let out = Path::new(env!("CARGO_TARGET_TMPDIR"))
                        .join(format!("fuzz-{parser}-crash-{seed}-{batch}"));
                    let _ = std::fs::write(&out, &input);
                    format!(
                        "{reason}\ninput ({} bytes, from corpus file {}, mutations {:?}), \
                         saved to {}:\n{}",
                        input.len(),
                        corpus[m.0].0,
                        m.1,
                        out.display(),
                        input.escape_ascii()
                    )
                }
                other => other.to_string(),
            };
            panic!("fuzz target {parser} (LUMIWALL_FUZZ_SEED={seed}): {detail}");
        }
        cases += 32;
        batch += 1;
    }
    eprintln!(
        "fuzz target {parser}: {cases} cases in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    cases
}
