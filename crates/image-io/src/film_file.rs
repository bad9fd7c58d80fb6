//! Partial films (`.rltfilm`): the state of a render over a range of
//! iterations, written by `render-cli --partial` and summed by `render-cli
//! merge`, so that the iterations of one image can be rendered on several
//! machines.
//!
//! Every iteration is a pure function of (scene, settings, seed, global
//! iteration index), so a film is its iteration range plus the per-pixel
//! sums and sums of squares of its estimates (light-tracing splats
//! included). Merging adds the sums of the shards in the order of their
//! ranges.
//!
//! # Format (little-endian)
//! | bytes | content |
//! |---|---|
//! | 8 | magic `RLTFILM\0` |
//! | 4 | format version, u32 ([`FORMAT_VERSION`]) |
//! | 4 | header length H, u32 |
//! | H | header: UTF-8 lines `key = value` (see [`FilmHeader`]) |
//! | 8 | iterations accumulated, u64 |
//! | 24 W H | per pixel, row-major: sum of the estimates, 3 x f64 |
//! | 24 W H | per pixel: sum of their squares, 3 x f64 |
//! | 4 | CRC-32 (ISO-HDLC, as zlib) of every byte before it |
//!
//! Version rule: a reader reads every version up to its own and refuses a
//! newer one, naming both. New information is added as header keys, which
//! readers that do not know them skip (no version change); the version
//! changes only when the binary layout does.

use std::fmt::Write as _;
use std::fs;
use std::io::{BufWriter, Read as _, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;

/// The first bytes of every partial film.
pub const MAGIC: &[u8; 8] = b"RLTFILM\0";

/// The binary layout written by this version.
pub const FORMAT_VERSION: u32 = 1;

/// Bytes before the header: magic, version, header length.
const PREAMBLE: usize = 16;

/// The file name extension of partial films.
pub const EXTENSION: &str = "rltfilm";

/// What a partial film says about the render it belongs to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FilmHeader {
    /// The scene file as given on the command line (for messages only).
    pub scene: String,
    /// A hash of the loaded scene's content: films of different scenes never merge.
    pub scene_hash: u64,
    /// Every resolved render setting (seed included), as one line.
    pub settings: String,
    /// The seed of every random stream (also in `settings`; for messages).
    pub seed: u64,
    /// First iteration, 1-based, inclusive.
    pub first: u64,
    /// Last iteration, inclusive.
    pub last: u64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Wall-clock milliseconds spent rendering the film, where recorded (a
    /// checkpoint of a `--time` render resumes with the rest of its time).
    pub render_millis: Option<u64>,
}

impl FilmHeader {
    /// The iteration range as the progress bar counts it, `first..last`.
    pub fn range(&self) -> String {
        format!("{}..{}", self.first, self.last)
    }

    fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "scene = {}", self.scene.replace('\n', " "));
        let _ = writeln!(s, "scene_hash = {:016x}", self.scene_hash);
        let _ = writeln!(s, "settings = {}", self.settings);
        let _ = writeln!(s, "seed = {}", self.seed);
        let _ = writeln!(s, "first = {}", self.first);
        let _ = writeln!(s, "last = {}", self.last);
        let _ = writeln!(s, "width = {}", self.width);
        let _ = writeln!(s, "height = {}", self.height);
        if let Some(ms) = self.render_millis {
            let _ = writeln!(s, "render_millis = {ms}");
        }
        s
    }

    fn from_text(text: &str) -> Result<Self, String> {
        let value = |key: &str| {
            text.lines()
                .find_map(|line| {
                    let (k, v) = line.split_once(" = ")?;
                    (k == key).then_some(v)
                })
                .ok_or_else(|| format!("header has no '{key}'"))
        };
        let number = |key: &str| {
            value(key)?
                .parse::<u64>()
                .map_err(|_| format!("header '{key}' is not a number"))
        };
        let size = |key: &str| {
            u32::try_from(number(key)?).map_err(|_| format!("header '{key}' is too large"))
        };
        let header = Self {
            scene: value("scene")?.to_owned(),
            scene_hash: u64::from_str_radix(value("scene_hash")?, 16)
                .map_err(|_| "header 'scene_hash' is not hexadecimal".to_owned())?,
            settings: value("settings")?.to_owned(),
            seed: number("seed")?,
            first: number("first")?,
            last: number("last")?,
            width: size("width")?,
            height: size("height")?,
            render_millis: match value("render_millis") {
                Ok(_) => Some(number("render_millis")?),
                Err(_) => None,
            },
        };
        if header.first == 0 || header.last < header.first {
            return Err(format!(
                "header range {} is empty or not 1-based",
                header.range()
            ));
        }
        Ok(header)
    }
}

/// A partial film: the header and the film's state.
#[derive(Clone, Debug, PartialEq)]
pub struct PartialFilm {
    /// Which render and which iterations.
    pub header: FilmHeader,
    /// Iterations accumulated (the range's length).
    pub iterations: u64,
    /// Per pixel, row-major: the sum of the estimates.
    pub sum: Vec<DVec3>,
    /// Per pixel: the sum of their squares.
    pub sum_sq: Vec<DVec3>,
}

impl PartialFilm {
    /// Adds `other`'s sums (the next range) to this film's.
    fn add(&mut self, other: &Self) {
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            *a += *b;
        }
        for (a, b) in self.sum_sq.iter_mut().zip(&other.sum_sq) {
            *a += *b;
        }
        self.iterations += other.iterations;
        self.header.last = other.header.last;
        self.header.render_millis = (self.header.render_millis)
            .zip(other.header.render_millis)
            .map(|(a, b)| a + b);
    }
}

/// A partial film could not be read, written or merged.
#[derive(Debug, thiserror::Error)]
pub enum FilmFileError {
    /// The file system refused.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is not a partial film, or is damaged.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The films do not belong to one render, or their ranges do not tile one range.
    #[error("{0}")]
    Mismatch(String),
}

/// Writes `partial` to `path` atomically ([`crate::atomic`]): an
/// interrupted write (a killed process, a full disk) never leaves a file
/// under `path` that a merge or a resumed render would accept, and leaves
/// the previous file, if any, as it was.
pub fn write(path: &Path, partial: &PartialFilm) -> Result<(), FilmFileError> {
    write_sums(
        path,
        &partial.header,
        partial.iterations,
        &partial.sum,
        partial.sum_sq.as_slice(),
    )
}

/// [`write()`] of a film's parts, streamed from where they are (a render's
/// film): no copy of the sums is made, which would double the memory of a
/// large film at every checkpoint.
pub fn write_sums(
    path: &Path,
    header: &FilmHeader,
    iterations: u64,
    sum: &[DVec3],
    sum_sq: &[DVec3],
) -> Result<(), FilmFileError> {
    let write = |temporary: &Path| -> std::io::Result<()> {
        let mut out = BufWriter::new(fs::File::create(temporary)?);
        encode_into(&mut out, header, iterations, sum, sum_sq)?;
        out.into_inner().map_err(|e| e.into_error())?;
        Ok(())
    };
    crate::atomic::write_atomically(path, write, |e| e).map_err(|source| FilmFileError::Io {
        path: path.to_owned(),
        source,
    })
}

/// Reads a partial film, checking magic, version, length and checksum.
pub fn read(path: &Path) -> Result<PartialFilm, FilmFileError> {
    let bytes = fs::read(path).map_err(|source| FilmFileError::Io {
        path: path.to_owned(),
        source,
    })?;
    decode(&bytes).map_err(|message| FilmFileError::Invalid {
        path: path.to_owned(),
        message,
    })
}

/// Bytes of pixel data encoded and checksummed at a time.
const ENCODE_CHUNK: usize = 1 << 16;

/// Writes the file format to `out`, checksumming as it goes.
fn encode_into(
    out: &mut impl Write,
    header: &FilmHeader,
    iterations: u64,
    sum: &[DVec3],
    sum_sq: &[DVec3],
) -> std::io::Result<()> {
    let text = header.to_text();
    let mut crc = crc32fast::Hasher::new();
    let mut put = |bytes: &[u8]| {
        crc.update(bytes);
        out.write_all(bytes)
    };
    put(MAGIC)?;
    put(&FORMAT_VERSION.to_le_bytes())?;
    put(&(text.len() as u32).to_le_bytes())?;
    put(text.as_bytes())?;
    put(&iterations.to_le_bytes())?;
    // In chunks: the checksum is fast on long runs of bytes.
    let mut chunk = Vec::with_capacity(ENCODE_CHUNK + 24);
    for v in sum.iter().chain(sum_sq) {
        for c in v.to_array() {
            chunk.extend_from_slice(&c.to_le_bytes());
        }
        if chunk.len() >= ENCODE_CHUNK {
            put(&chunk)?;
            chunk.clear();
        }
    }
    put(&chunk)?;
    out.write_all(&crc.finalize().to_le_bytes())
}

#[cfg(test)]
fn encode(partial: &PartialFilm) -> Vec<u8> {
    let mut bytes = Vec::new();
    encode_into(
        &mut bytes,
        &partial.header,
        partial.iterations,
        &partial.sum,
        &partial.sum_sq,
    )
    .expect("writing to memory");
    bytes
}

/// Checks magic and version; returns the header length.
fn check_preamble(bytes: &[u8]) -> Result<usize, String> {
    if bytes.len() < PREAMBLE || &bytes[..8] != MAGIC {
        return Err("not a partial film (no RLTFILM magic number)".to_owned());
    }
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let version = u32_at(8);
    if version > FORMAT_VERSION {
        return Err(format!(
            "written in partial-film format {version}; this render-cli reads up to {FORMAT_VERSION}"
        ));
    }
    Ok(u32_at(12) as usize)
}

fn decode(bytes: &[u8]) -> Result<PartialFilm, String> {
    let header_end = PREAMBLE + check_preamble(bytes)?;
    let text = bytes
        .get(PREAMBLE..header_end)
        .ok_or("truncated (the header is cut off)")?;
    let text = std::str::from_utf8(text).map_err(|_| "header is not UTF-8".to_owned())?;
    let header = FilmHeader::from_text(text)?;
    let pixels = header.width as usize * header.height as usize;
    let expected = header_end + 8 + 48 * pixels + 4;
    if bytes.len() != expected {
        return Err(format!(
            "{} bytes, expected {expected} for {}x{} pixels (truncated or damaged)",
            bytes.len(),
            header.width,
            header.height
        ));
    }
    let (body, crc) = bytes.split_at(expected - 4);
    if crc32fast::hash(body) != u32::from_le_bytes(crc.try_into().expect("4 bytes")) {
        return Err("checksum mismatch (the file is damaged)".to_owned());
    }
    let iterations = u64::from_le_bytes(body[header_end..header_end + 8].try_into().expect("8"));
    if iterations != header.last - header.first + 1 {
        return Err(format!(
            "holds {iterations} iterations, but its range {} has {}",
            header.range(),
            header.last - header.first + 1
        ));
    }
    let mut values = body[header_end + 8..].chunks_exact(24).map(|c| {
        DVec3::from_array(std::array::from_fn(|k| {
            f64::from_le_bytes(c[8 * k..8 * k + 8].try_into().expect("8 bytes"))
        }))
    });
    let sum: Vec<DVec3> = values.by_ref().take(pixels).collect();
    let sum_sq: Vec<DVec3> = values.collect();
    Ok(PartialFilm {
        header,
        iterations,
        sum,
        sum_sq,
    })
}

/// Reads only the header of a partial film (the pixel data is checked when
/// it is read whole).
pub fn read_header(path: &Path) -> Result<FilmHeader, FilmFileError> {
    let invalid = |message: String| FilmFileError::Invalid {
        path: path.to_owned(),
        message,
    };
    let io = |source| FilmFileError::Io {
        path: path.to_owned(),
        source,
    };
    let mut file = fs::File::open(path).map_err(io)?;
    let mut preamble = [0u8; PREAMBLE];
    file.read_exact(&mut preamble)
        .map_err(|_| invalid("truncated (shorter than the preamble)".to_owned()))?;
    let header_len = check_preamble(&preamble).map_err(invalid)?;
    let mut text = vec![0u8; header_len];
    file.read_exact(&mut text)
        .map_err(|_| invalid("truncated (the header is cut off)".to_owned()))?;
    let text = std::str::from_utf8(&text).map_err(|_| invalid("header is not UTF-8".to_owned()))?;
    FilmHeader::from_text(text).map_err(invalid)
}

/// What makes two films' renders differ (see [`difference`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DifferenceKind {
    /// The scenes' content (their hashes).
    Scene,
    /// The image sizes.
    Resolution,
    /// A render setting (seed included).
    Settings,
}

impl DifferenceKind {
    /// The noun before a value: "resolution 64x48" (empty for settings,
    /// whose values name their field).
    pub fn noun(self) -> &'static str {
        match self {
            Self::Scene => "scene ",
            Self::Resolution => "resolution ",
            Self::Settings => "",
        }
    }

    /// The plural, as in "different sizes".
    pub fn plural(self) -> &'static str {
        match self {
            Self::Scene => "scenes",
            Self::Resolution => "sizes",
            Self::Settings => "settings",
        }
    }
}

/// The first difference between the renders of two films, each side as a
/// short value: `64x48`, `max_depth: 12`, `regularization.mode: Uniform`, a
/// scene's file and content hash.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Difference {
    /// What differs.
    pub kind: DifferenceKind,
    /// The first film's value.
    pub ours: String,
    /// The second film's value.
    pub theirs: String,
}

/// How the renders of `a` and `b` differ (size, scene content, settings),
/// if they do; the iteration ranges and render times are not compared.
pub fn difference(a: &FilmHeader, b: &FilmHeader) -> Option<Difference> {
    // Size first: the camera, and so the scene's hash, includes it.
    let (kind, ours, theirs) = if (a.width, a.height) != (b.width, b.height) {
        let size = |h: &FilmHeader| format!("{}x{}", h.width, h.height);
        (DifferenceKind::Resolution, size(a), size(b))
    } else if a.scene_hash != b.scene_hash {
        let scene = |h: &FilmHeader| format!("{} (content hash {:016x})", h.scene, h.scene_hash);
        (DifferenceKind::Scene, scene(a), scene(b))
    } else if a.settings != b.settings {
        let (ours, theirs) = debug_difference(&a.settings, &b.settings, "")
            .unwrap_or_else(|| (a.settings.clone(), b.settings.clone()));
        (DifferenceKind::Settings, ours, theirs)
    } else {
        return None;
    };
    Some(Difference { kind, ours, theirs })
}

/// The first field in which two `Debug` lines of one struct type differ,
/// as `path.to.field: value` on each side (nested structs are entered);
/// `None` where they are not structs of the same shape.
fn debug_difference(a: &str, b: &str, prefix: &str) -> Option<(String, String)> {
    let (name_a, fields_a) = debug_fields(a)?;
    let (name_b, fields_b) = debug_fields(b)?;
    if name_a != name_b || fields_a.len() != fields_b.len() {
        return None;
    }
    let (x, y) = fields_a.iter().zip(&fields_b).find(|(x, y)| x != y)?;
    Some(match (x.split_once(": "), y.split_once(": ")) {
        (Some((kx, vx)), Some((ky, vy))) if kx == ky => {
            let path = format!("{prefix}{kx}");
            debug_difference(vx, vy, &format!("{path}."))
                .unwrap_or_else(|| (format!("{path}: {vx}"), format!("{path}: {vy}")))
        }
        _ => (format!("{prefix}{x}"), format!("{prefix}{y}")),
    })
}

/// `Name { a: 1, b: X { c: 2 } }` as its name and its top-level fields.
fn debug_fields(s: &str) -> Option<(&str, Vec<&str>)> {
    let (name, rest) = s.split_once(" { ")?;
    let inner = rest.strip_suffix(" }")?;
    if name.contains([' ', '(', '[', '{', '"']) {
        return None;
    }
    let mut fields = Vec::new();
    let (mut depth, mut quoted, mut start) = (0i32, false, 0);
    let bytes = inner.as_bytes();
    for (i, &c) in bytes.iter().enumerate() {
        match c {
            b'"' if i == 0 || bytes[i - 1] != b'\\' => quoted = !quoted,
            b'{' | b'(' | b'[' if !quoted => depth += 1,
            b'}' | b')' | b']' if !quoted => depth -= 1,
            b',' if !quoted && depth == 0 => {
                fields.push(inner[start..i].trim());
                start = i + 1;
            }
            _ => {}
        }
    }
    fields.push(inner[start..].trim());
    Some((name, fields))
}

/// Sums the partial films at `paths` (given in any order) into the film of
/// the union of their ranges. Refuses films of different scenes, settings
/// or sizes, and ranges that overlap or leave a gap, naming the files;
/// then reads the films one at a time (memory: two films). The sums are
/// added in the order of the ranges, in f64: the result equals the
/// single-process render to f64 rounding, which the f32 image hides
/// (see `tests`).
pub fn merge(paths: &[PathBuf]) -> Result<PartialFilm, FilmFileError> {
    let headers = paths
        .iter()
        .map(|p| Ok((p.clone(), read_header(p)?)))
        .collect::<Result<Vec<_>, FilmFileError>>()?;
    let order = merge_order(&headers).map_err(FilmFileError::Mismatch)?;
    let mut merged: Option<PartialFilm> = None;
    for i in order {
        let (path, header) = &headers[i];
        let film = read(path)?;
        if film.header != *header {
            return Err(FilmFileError::Mismatch(format!(
                "{} changed while it was being merged",
                path.display()
            )));
        }
        match &mut merged {
            None => merged = Some(film),
            Some(m) => m.add(&film),
        }
    }
    merged.ok_or_else(|| FilmFileError::Mismatch("no partial film to merge".to_owned()))
}

/// The order (by range) in which `headers` tile one range of one render, or
/// why they do not.
fn merge_order(headers: &[(PathBuf, FilmHeader)]) -> Result<Vec<usize>, String> {
    let mut order: Vec<usize> = (0..headers.len()).collect();
    order.sort_by_key(|&i| headers[i].1.first);
    let Some(&first) = order.first() else {
        return Err("no partial film to merge".to_owned());
    };
    let name = |i: usize| headers[i].0.display().to_string();
    let reference = &headers[first].1;
    for pair in order.windows(2) {
        let (i, j) = (pair[0], pair[1]);
        let (a, b) = (&headers[i].1, &headers[j].1);
        if let Some(d) = difference(reference, b) {
            return Err(format!(
                "{} and {} are of different renders: different {} ({} and {})",
                name(first),
                name(j),
                d.kind.plural(),
                d.ours,
                d.theirs
            ));
        }
        if b.first <= a.last {
            return Err(format!(
                "{} ({}) and {} ({}) overlap",
                name(i),
                a.range(),
                name(j),
                b.range()
            ));
        }
        if b.first > a.last + 1 {
            return Err(format!(
                "iterations {}..{} are missing (between {} and {})",
                a.last + 1,
                b.first - 1,
                name(i),
                name(j)
            ));
        }
    }
    Ok(order)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(first: u64, last: u64) -> FilmHeader {
        FilmHeader {
            scene: "scenes/x/scene.toml".to_owned(),
            scene_hash: 0x0123_4567_89ab_cdef,
            settings: "RenderConfig { seed: 3 }".to_owned(),
            seed: 3,
            first,
            last,
            width: 3,
            height: 2,
            render_millis: None,
        }
    }

    /// A film over `first..=last` whose estimates are a function of the
    /// global iteration index, summed one iteration at a time like a render.
    fn partial(first: u64, last: u64) -> PartialFilm {
        let (mut sum, mut sum_sq) = (vec![DVec3::ZERO; 6], vec![DVec3::ZERO; 6]);
        for n in first..=last {
            for p in 0..6 {
                let x = glam::Vec3::new(
                    n as f32 * 0.37 + p as f32,
                    1.0 / n as f32,
                    (n * n) as f32 * 1e-3,
                )
                .as_dvec3();
                sum[p] += x;
                sum_sq[p] += x * x;
            }
        }
        PartialFilm {
            header: header(first, last),
            iterations: last - first + 1,
            sum,
            sum_sq,
        }
    }

    /// The f32 mean image of a film.
    fn mean(f: &PartialFilm) -> Vec<glam::Vec3> {
        f.sum
            .iter()
            .map(|s| (*s / f.iterations as f64).as_vec3())
            .collect()
    }

    #[test]
    fn a_film_survives_the_round_trip_exactly() {
        let p = partial(5, 9);
        assert_eq!(decode(&encode(&p)).unwrap(), p);
    }

    #[test]
    fn damage_is_refused_with_a_reason() {
        let bytes = encode(&partial(1, 4));
        let err = |b: &[u8]| decode(b).unwrap_err();
        assert!(err(&bytes[..bytes.len() - 1]).contains("truncated"));
        assert!(err(&bytes[..20]).contains("truncated"));
        let mut flipped = bytes.clone();
        flipped[bytes.len() / 2] ^= 0x10;
        assert!(err(&flipped).contains("checksum"));
        assert!(err(b"P6 3 2 255\n").contains("magic"));
        let mut newer = bytes.clone();
        newer[8] = 2;
        assert!(err(&newer).contains("format 2"));
    }

    #[test]
    fn render_time_is_kept_when_recorded() {
        let mut p = partial(1, 3);
        p.header.render_millis = Some(1234);
        assert_eq!(decode(&encode(&p)).unwrap(), p);
    }

    #[test]
    fn differences_name_the_field() {
        let a = header(1, 2);
        let mut b = a.clone();
        b.settings = "RenderConfig { seed: 3, regularization: Regularization { mode: \
                      Uniform, tau: Some(3.0) }, max_depth: 2 }"
            .to_owned();
        let mut c = b.clone();
        c.settings = c.settings.replace("Some(3.0)", "Some(7.5)");
        let d = difference(&b, &c).unwrap();
        assert_eq!(d.kind, DifferenceKind::Settings);
        assert_eq!(
            (d.ours.as_str(), d.theirs.as_str()),
            (
                "regularization.tau: Some(3.0)",
                "regularization.tau: Some(7.5)"
            )
        );
        // Not of one shape: the whole lines.
        let d = difference(&a, &b).unwrap();
        assert_eq!((d.ours, d.theirs), (a.settings.clone(), b.settings.clone()));
        c = a.clone();
        c.width = 64;
        let d = difference(&a, &c).unwrap();
        assert_eq!(
            (d.kind, d.ours.as_str(), d.theirs.as_str()),
            (DifferenceKind::Resolution, "3x2", "64x2")
        );
        c.scene_hash = 1;
        assert_eq!(difference(&a, &c).unwrap().kind, DifferenceKind::Resolution);
        c.width = a.width;
        assert_eq!(difference(&a, &c).unwrap().kind, DifferenceKind::Scene);
        c = a.clone();
        c.first = 7;
        c.render_millis = Some(5);
        assert_eq!(difference(&a, &c), None);
    }

    #[test]
    fn unknown_header_keys_are_skipped() {
        let mut text = header(1, 2).to_text();
        text.push_str("future_key = anything\n");
        assert_eq!(FilmHeader::from_text(&text).unwrap(), header(1, 2));
    }

    /// Writes each film to a file of a fresh folder named after its range.
    fn files(name: &str, films: Vec<PartialFilm>) -> Vec<PathBuf> {
        let dir = std::env::temp_dir().join(format!("rlt-film-{name}-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        films
            .into_iter()
            .map(|f| {
                let path = dir.join(format!("{}.{EXTENSION}", f.header.range()));
                write(&path, &f).unwrap();
                path
            })
            .collect()
    }

    /// Shards in any order merge into the film of the whole range, equal
    /// to the single-process film to f64 rounding and identical once the
    /// mean is rounded to f32 (the image); merges merge again.
    #[test]
    fn shards_merge_in_any_order_and_hierarchically() {
        let whole = partial(1, 40);
        let shards = files(
            "any-order",
            vec![partial(21, 40), partial(1, 7), partial(8, 20)],
        );
        let merged = merge(&shards).unwrap();
        assert_eq!(merged.header, header(1, 40));
        assert_eq!(mean(&merged), mean(&whole));
        for (x, y) in merged.sum.iter().zip(&whole.sum) {
            assert!(((*x - *y) / *y).abs().max_element() < 1e-14, "{x} {y}");
        }
        let halves = files("halves", vec![partial(1, 10), partial(11, 20)]);
        let mut half = merge(&halves).unwrap();
        half.header.first = 1;
        let again = files("again", vec![half, partial(21, 40)]);
        assert_eq!(mean(&merge(&again).unwrap()), mean(&whole));
        for path in shards.iter().chain(&halves).chain(&again) {
            let _ = fs::remove_dir_all(path.parent().unwrap());
        }
    }

    #[test]
    fn gaps_overlaps_and_foreign_films_are_named() {
        let named = |name: &str, f: PartialFilm| (PathBuf::from(name), f.header);
        let message = |headers: Vec<(PathBuf, FilmHeader)>| merge_order(&headers).unwrap_err();
        let gap = message(vec![named("a", partial(1, 8)), named("b", partial(12, 20))]);
        assert!(gap.contains("9..11 are missing (between a and b)"), "{gap}");
        let overlap = message(vec![named("b", partial(5, 20)), named("a", partial(1, 8))]);
        assert!(
            overlap.contains("a (1..8) and b (5..20) overlap"),
            "{overlap}"
        );
        let mut other = partial(9, 10);
        other.header.settings = "RenderConfig { seed: 4 }".to_owned();
        let foreign = message(vec![named("a", partial(1, 8)), named("b", other)]);
        assert!(
            foreign.contains("different settings (seed: 3 and seed: 4)"),
            "{foreign}"
        );
        let mut moved = partial(9, 10);
        moved.header.scene_hash ^= 1;
        let scenes = message(vec![named("a", partial(1, 8)), named("b", moved)]);
        assert!(scenes.contains("different scenes"), "{scenes}");
        assert!(merge_order(&[]).unwrap_err().contains("no partial film"));
    }
}
