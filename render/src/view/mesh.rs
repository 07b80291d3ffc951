//! A radiosity solution as a lit mesh: positions, per-vertex luminance and faces, from
//! a [`Solution`] in memory or from the ASCII PLY that `lumiwall render` writes
//! ([`crate::radiosity::output::write_ply`]).

use std::path::Path;

use crate::radiosity::Solution;
use crate::radiosity::output::vertex_luminance;
use crate::scene::{V3, polygon_normal};

/// Most vertices a PLY may declare (a solution of a few million patches).
pub const MAX_VERTICES: usize = 20_000_000;

/// Largest solution file read (bytes): about 20 million vertices as text.
pub const MAX_FILE_BYTES: u64 = 4 << 30;

/// Most vertices of one face.
pub const MAX_FACE_VERTICES: usize = 64;

/// Why a solution file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be read.
    #[error("solution {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// What the system said.
        source: std::io::Error,
    },
    /// The file is not a solution PLY as `lumiwall render` writes it.
    #[error(
        "solution {path}, line {line}: {message} (expected the ASCII PLY `lumiwall render` writes)"
    )]
    Format {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Positions (m), per-vertex luminance (XYZ, Y in cd/m²) and faces (vertex indices,
/// counter-clockwise seen from the lit side).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LitMesh {
    /// Vertex positions in the scene (m).
    pub positions: Vec<V3>,
    /// Luminance of each vertex (XYZ, cd/m²).
    pub luminance_xyz: Vec<[f64; 3]>,
    /// Faces: indices into `positions`, wound counter-clockwise seen from the front.
    pub faces: Vec<Vec<u32>>,
}

impl LitMesh {
    /// The solution's patches with their vertices' luminance
    /// ([`vertex_luminance`]); each face wound so that it faces where its patch's
    /// normal points, from the patch's first vertex (a face turned round keeps it, so
    /// its fan of triangles is the patch's own).
    pub fn from_solution(sol: &Solution) -> Self {
        let lum = vertex_luminance(sol);
        let mut mesh = LitMesh::default();
        for (p, l) in sol.patches.iter().zip(&lum) {
            let first = mesh.positions.len() as u32;
            mesh.positions.extend(p.vertices.iter().copied());
            mesh.luminance_xyz.extend(l.iter().copied());
            let mut face: Vec<u32> = (first..first + p.vertices.len() as u32).collect();
            if polygon_normal(&p.vertices).is_some_and(|n| n.dot(&p.normal) < 0.0) {
                face[1..].reverse();
            }
            mesh.faces.push(face);
        }
        mesh
    }

    /// Reads the ASCII PLY `lumiwall render` writes (vertex x y z lum_X lum_Y lum_Z,
    /// faces as index lists); the file's size is checked before it is read
    /// ([`MAX_FILE_BYTES`]), the counts its header states before anything is reserved.
    pub fn read_ply(path: &Path) -> Result<Self, MeshError> {
        let io = |source| MeshError::Io {
            path: path.display().to_string(),
            source,
        };
        let bytes = std::fs::metadata(path).map_err(io)?.len();
        if bytes > MAX_FILE_BYTES {
            return Err(MeshError::Format {
                path: path.display().to_string(),
                line: 0,
                message: format!("{bytes} bytes: at most {MAX_FILE_BYTES}"),
            });
        }
        let text = std::fs::read_to_string(path).map_err(|source| MeshError::Io {
            path: path.display().to_string(),
            source,
        })?;
        parse_ply(&text).map_err(|(line, message)| MeshError::Format {
            path: path.display().to_string(),
            line,
            message,
        })
    }

    /// True when `face` turns its front to `eye` (its plane's normal, from its
    /// winding, points to the eye's side).
    pub fn faces_eye(&self, face: &[u32], eye: &V3) -> bool {
        let pts: Vec<V3> = face.iter().map(|&i| self.positions[i as usize]).collect();
        match (pts.first(), polygon_normal(&pts)) {
            (Some(p0), Some(n)) => n.dot(&(eye - p0)) > 0.0,
            _ => false,
        }
    }
}

type ParseError = (usize, String);

/// The header's vertex and face counts.
fn header_counts(
    lines: &mut std::iter::Enumerate<std::str::Lines<'_>>,
) -> Result<(usize, usize, usize), ParseError> {
    let (mut vertices, mut faces) = (None, None);
    let mut vertex_properties: Vec<String> = Vec::new();
    let mut last = 0;
    for (i, line) in lines.by_ref() {
        last = i + 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["ply"] | ["comment", ..] => {}
            ["property", "list", ..] => {}
            ["property", _, name] if faces.is_none() => vertex_properties.push(name.to_string()),
            ["property", ..] => {}
            ["format", "ascii", "1.0"] => {}
            ["format", other, ..] => {
                return Err((last, format!("format {other}: only ascii is read")));
            }
            ["element", "vertex", n] => vertices = Some(parse_count(n, last)?),
            ["element", "face", n] => faces = Some(parse_count(n, last)?),
            ["end_header"] => {
                check_vertex_properties(&vertex_properties, last)?;
                let v = vertices.ok_or((last, "no vertex element".to_string()))?;
                let f = faces.ok_or((last, "no face element".to_string()))?;
                if v > MAX_VERTICES || f > v || f == 0 {
                    return Err((
                        last,
                        format!(
                            "{v} vertices and {f} faces: at most {MAX_VERTICES} vertices, at least one face and no more faces than vertices"
                        ),
                    ));
                }
                return Ok((v, f, last));
            }
            _ => return Err((last, format!("unexpected header line {line:?}"))),
        }
    }
    Err((last, "no end_header".into()))
}

/// The vertex properties `write_ply` writes, in its order: another tool's PLY (normals,
/// colours) must not be read as luminance.
fn check_vertex_properties(names: &[String], line: usize) -> Result<(), ParseError> {
    const EXPECTED: [&str; 6] = ["x", "y", "z", "lum_X", "lum_Y", "lum_Z"];
    if names.iter().map(String::as_str).eq(EXPECTED) {
        Ok(())
    } else {
        Err((
            line,
            format!("vertex properties {names:?}: expected {EXPECTED:?} (luminance in cd/m²)"),
        ))
    }
}

fn parse_count(word: &str, line: usize) -> Result<usize, ParseError> {
    word.parse()
        .map_err(|_| (line, format!("{word:?} is not a count")))
}

fn parse_numbers(line: &str, n: usize, at: usize) -> Result<Vec<f64>, ParseError> {
    let v: Vec<f64> = line
        .split_whitespace()
        .map(|w| {
            w.parse::<f64>()
                .map_err(|_| (at, format!("{w:?} is not a number")))
        })
        .collect::<Result<_, _>>()?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err((at, format!("expected {n} finite numbers, got {line:?}")));
    }
    Ok(v)
}

fn parse_ply(text: &str) -> Result<LitMesh, ParseError> {
    let mut lines = text.lines().enumerate();
    let (nv, nf, header_end) = header_counts(&mut lines)?;
    // Every vertex line holds at least six numbers (12 bytes): a header that promises
    // more vertices than the file can hold reserves no more than the file's size.
    let most = text.len() / 12;
    let mut mesh = LitMesh {
        positions: Vec::with_capacity(nv.min(most)),
        luminance_xyz: Vec::with_capacity(nv.min(most)),
        faces: Vec::with_capacity(nf.min(most)),
    };
    let mut at = header_end;
    let mut next = |what: &str| match lines.next() {
        Some((i, l)) => {
            at = i + 1;
            Ok((i + 1, l))
        }
        None => Err((at + 1, format!("file ends before the {what}"))),
    };
    for _ in 0..nv {
        let (i, line) = next("vertices")?;
        let v = parse_numbers(line, 6, i)?;
        mesh.positions.push(V3::new(v[0], v[1], v[2]));
        mesh.luminance_xyz.push([v[3], v[4], v[5]]);
    }
    for _ in 0..nf {
        let (i, line) = next("faces")?;
        let words: Vec<&str> = line.split_whitespace().collect();
        let n = words
            .first()
            .map(|w| parse_count(w, i))
            .transpose()?
            .unwrap_or(0);
        if !(3..=MAX_FACE_VERTICES).contains(&n) || words.len() != n + 1 {
            return Err((
                i,
                format!("a face needs 3 to {MAX_FACE_VERTICES} vertex indices, got {line:?}"),
            ));
        }
        let face: Vec<u32> = words[1..]
            .iter()
            .map(|w| {
                w.parse::<u32>()
                    .ok()
                    .filter(|k| (*k as usize) < nv)
                    .ok_or((i, format!("{w:?} is not a vertex index below {nv}")))
            })
            .collect::<Result<_, _>>()?;
        mesh.faces.push(face);
    }
    Ok(mesh)
}
