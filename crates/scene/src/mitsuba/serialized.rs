//! Mitsuba's `.serialized` meshes (format 0x041C, versions 3 and 4), as
//! Mitsuba 3.9.1 reads them (`src/shapes/serialized.cpp`; the layout is in
//! `shared/notes/mitsuba-format.md`, section 6).
//!
//! A file is a run of mesh blocks, each a 4-byte header (`u16` format,
//! `u16` version) and a zlib stream, followed by a table of the blocks'
//! byte offsets (`u32` in v3, `u64` in v4) and a `u32` count. The stream
//! holds `u32` flags, in v4 a NUL-terminated name, `u64` vertex and
//! triangle counts, the vertex arrays (positions, then normals, texture
//! coordinates and colours as the flags say; `f32` or `f64` reals) and the
//! triangles (`u32` indices). All values are little-endian.
//!
//! The input may be hostile: every count is checked against what the
//! compressed bytes can inflate to (`MAX_INFLATE_RATIO`) and against
//! [`MAX_MESH_BYTES`] before anything is allocated, the stream is read
//! through [`Read::take`] with that bound, indices are checked against the
//! vertex count and positions must be finite. Errors are one line.

use std::io::{self, BufRead, BufReader, Read};

use flate2::read::ZlibDecoder;
use glam::{Vec2, Vec3};

use super::MeshData;

/// First `u16` of every mesh block.
const FORMAT_MAGIC: u16 = 0x041C;

/// Version whose offset table holds `u32` entries and whose meshes have no name.
const VERSION_3: u16 = 3;

/// Version whose offset table holds `u64` entries and whose meshes start
/// with a NUL-terminated name.
const VERSION_4: u16 = 4;

/// Bytes of a mesh block's uncompressed header: format and version, two `u16`.
const BLOCK_HEADER_BYTES: usize = 4;

/// Bytes of the mesh count that ends the file.
const COUNT_BYTES: usize = 4;

/// Flag: the stream holds one normal per vertex.
const FLAG_NORMALS: u32 = 0x0001;

/// Flag: the stream holds one texture coordinate pair per vertex.
const FLAG_TEXCOORDS: u32 = 0x0002;

/// Flag: the stream holds one RGB colour per vertex (read past, unused).
const FLAG_COLORS: u32 = 0x0008;

/// Flag: reals are `f64` (otherwise `f32`; the single-precision flag
/// 0x1000 is implied, as in Mitsuba).
const FLAG_DOUBLE: u32 = 0x2000;

/// Most bytes a zlib stream can inflate to per compressed byte: deflate's
/// densest code is a 258-byte match in two bits, so 258 * 8 / 2 = 1032.
/// A header claiming more data than `compressed bytes * 1032` is lying.
const MAX_INFLATE_RATIO: u64 = 1032;

/// Most bytes of vertex and triangle data one mesh may hold (4 GiB, about
/// 180 million triangles with normals and texture coordinates): beyond any
/// scene this renderer is meant for, and a bound on what a file can make
/// it allocate even when its stream really does inflate that far.
pub const MAX_MESH_BYTES: u64 = 4 << 30;

/// Longest v4 mesh name skipped before an error: names are labels, and
/// the bound keeps a stream of non-NUL bytes from being inflated in full.
const MAX_NAME_BYTES: u64 = 1 << 16;

/// Bytes of the stream before the vertex data, name excluded: flags and
/// the two counts.
const FIXED_HEADER_BYTES: u64 = 4 + 8 + 8;

/// Inflated bytes buffered between the zlib decoder and the value reads,
/// so that a 12-byte read does not run the decoder by itself.
const INFLATE_BUFFER: usize = 1 << 16;

/// Number of meshes in a `.serialized` file, from its offset table.
pub fn mesh_count(bytes: &[u8]) -> Result<u32, String> {
    let version = file_version(bytes)?;
    Ok(OffsetTable::parse(bytes, version)?.count)
}

/// Reads mesh `shape_index` (0 is the first) of a `.serialized` file.
///
/// Mesh 0 is read from the start of the file, as Mitsuba does, without
/// the offset table; other meshes are found through the table.
pub fn read(bytes: &[u8], shape_index: u32) -> Result<MeshData, String> {
    let version = file_version(bytes)?;
    let stream = if shape_index == 0 {
        &bytes[BLOCK_HEADER_BYTES..]
    } else {
        let table = OffsetTable::parse(bytes, version)?;
        &bytes[table.stream_range(bytes, shape_index)?]
    };
    read_mesh(stream, version).map_err(|e| format!("mesh {shape_index}: {e}"))
}

/// Checks the first block header and returns the file's version (Mitsuba
/// takes every mesh's version from the first header).
fn file_version(bytes: &[u8]) -> Result<u16, String> {
    let Some(header) = bytes.get(..BLOCK_HEADER_BYTES) else {
        return Err(format!(
            "not a .serialized file: {} bytes, shorter than the {BLOCK_HEADER_BYTES}-byte header",
            bytes.len()
        ));
    };
    let magic = u16::from_le_bytes([header[0], header[1]]);
    if magic != FORMAT_MAGIC {
        return Err(format!(
            "not a .serialized file: it starts with {magic:#06x}, not {FORMAT_MAGIC:#06x}"
        ));
    }
    match u16::from_le_bytes([header[2], header[3]]) {
        version @ (VERSION_3 | VERSION_4) => Ok(version),
        version => Err(format!(
            "unsupported .serialized version {version} (Mitsuba 3 reads versions 3 and 4)"
        )),
    }
}

/// The table of mesh offsets at the end of a file.
struct OffsetTable {
    /// Number of meshes.
    count: u32,
    /// Bytes of one offset: 4 in v3, 8 in v4.
    entry_bytes: usize,
    /// Byte position of the table's first entry (the end of the last mesh).
    start: usize,
}

impl OffsetTable {
    /// Locates the table from the count in the last four bytes.
    fn parse(bytes: &[u8], version: u16) -> Result<Self, String> {
        let entry_bytes = if version == VERSION_3 { 4 } else { 8 };
        let count_at = bytes.len().saturating_sub(COUNT_BYTES);
        let count = u32::from_le_bytes(le_array(bytes, count_at).ok_or("file too short")?);
        let start = usize::try_from(count)
            .ok()
            .and_then(|c| c.checked_mul(entry_bytes))
            .and_then(|table| count_at.checked_sub(table))
            .filter(|&start| start >= BLOCK_HEADER_BYTES)
            .ok_or_else(|| {
                format!(
                    "offset table of {count} meshes does not fit in the {}-byte file",
                    bytes.len()
                )
            })?;
        Ok(Self {
            count,
            entry_bytes,
            start,
        })
    }

    /// Byte offset of mesh `k`'s block header, as stored.
    fn offset(&self, bytes: &[u8], k: u32) -> u64 {
        // In range: k < count, and the table fits in the file (`parse`).
        let at = self.start + k as usize * self.entry_bytes;
        if self.entry_bytes == 4 {
            le_array(bytes, at).map_or(u64::MAX, |b| u64::from(u32::from_le_bytes(b)))
        } else {
            le_array(bytes, at).map_or(u64::MAX, u64::from_le_bytes)
        }
    }

    /// The bytes of mesh `k`'s zlib stream: from after its block header to
    /// the next mesh's offset, or to the table for the last mesh.
    fn stream_range(&self, bytes: &[u8], k: u32) -> Result<std::ops::Range<usize>, String> {
        if k >= self.count {
            return Err(format!(
                "shape_index {k} out of range: the file holds {} meshes",
                self.count
            ));
        }
        let offset = self.offset(bytes, k);
        let end = if k + 1 < self.count {
            self.offset(bytes, k + 1)
        } else {
            self.start as u64
        };
        let fits = end <= self.start as u64
            && offset
                .checked_add(BLOCK_HEADER_BYTES as u64)
                .is_some_and(|stream| stream <= end);
        if !fits {
            return Err(format!(
                "offset table: mesh {k} at byte {offset} does not end before byte {end}"
            ));
        }
        // `offset + 4 <= end <= start`, a position in `bytes`: the casts are exact.
        let header = offset as usize;
        if le_array(bytes, header).map(u16::from_le_bytes) != Some(FORMAT_MAGIC) {
            return Err(format!(
                "offset table: no mesh header ({FORMAT_MAGIC:#06x}) at byte {offset} for mesh {k}"
            ));
        }
        Ok(header + BLOCK_HEADER_BYTES..end as usize)
    }
}

/// `N` bytes at `at`, if the slice holds them.
fn le_array<const N: usize>(bytes: &[u8], at: usize) -> Option<[u8; N]> {
    bytes.get(at..at.checked_add(N)?)?.try_into().ok()
}

/// What the flags say a mesh's vertices hold.
#[derive(Clone, Copy, Debug)]
struct Layout {
    /// Vertex normals follow the positions.
    normals: bool,
    /// Texture coordinates follow.
    uvs: bool,
    /// Vertex colours follow (read past).
    colors: bool,
    /// Reals are `f64`, not `f32`.
    double: bool,
}

impl Layout {
    /// The layout the stream's flags describe.
    fn new(flags: u32) -> Self {
        Self {
            normals: flags & FLAG_NORMALS != 0,
            uvs: flags & FLAG_TEXCOORDS != 0,
            colors: flags & FLAG_COLORS != 0,
            double: flags & FLAG_DOUBLE != 0,
        }
    }

    /// Bytes of one real.
    fn real_bytes(self) -> u64 {
        if self.double { 8 } else { 4 }
    }

    /// Bytes of one vertex's data.
    fn vertex_bytes(self) -> u64 {
        let reals =
            3 + 3 * u64::from(self.normals) + 2 * u64::from(self.uvs) + 3 * u64::from(self.colors);
        reals * self.real_bytes()
    }
}

/// Bytes of one triangle: three `u32` indices.
const TRIANGLE_BYTES: u64 = 12;

/// Reads one mesh from its zlib stream (`compressed`, which may run on
/// past the stream's end).
fn read_mesh(compressed: &[u8], version: u16) -> Result<MeshData, String> {
    let compressed_len = compressed.len() as u64;
    let inflate_bound = compressed_len.saturating_mul(MAX_INFLATE_RATIO);
    let header_bound = FIXED_HEADER_BYTES + MAX_NAME_BYTES + 1;
    let limit = inflate_bound.min(header_bound + MAX_MESH_BYTES);
    let mut reader =
        BufReader::with_capacity(INFLATE_BUFFER, ZlibDecoder::new(compressed).take(limit));
    let flags = read_u32(&mut reader).map_err(stream_error("flags"))?;
    if version == VERSION_4 {
        skip_name(&mut reader)?;
    }
    let vertex_count = read_u64(&mut reader).map_err(stream_error("vertex count"))?;
    let triangle_count = read_u64(&mut reader).map_err(stream_error("triangle count"))?;
    let layout = Layout::new(flags);
    check_counts(vertex_count, triangle_count, layout, compressed_len)?;
    // Both counts fit in `MAX_MESH_BYTES`, so in `usize` on 64-bit targets.
    let to_usize =
        |n: u64| usize::try_from(n).map_err(|_| format!("{n} items do not fit in memory"));
    let (vertices, triangles) = (to_usize(vertex_count)?, to_usize(triangle_count)?);
    read_arrays(&mut reader, layout, vertices, triangles)
}

/// Checks the claimed counts against the data the stream can hold, before
/// anything is allocated for them.
fn check_counts(
    vertices: u64,
    triangles: u64,
    layout: Layout,
    compressed_len: u64,
) -> Result<(), String> {
    let inflate_bound = compressed_len.saturating_mul(MAX_INFLATE_RATIO);
    let vertex_bytes = vertices
        .checked_mul(layout.vertex_bytes())
        .filter(|&b| b <= inflate_bound)
        .ok_or_else(|| {
            format!("header claims {vertices} vertices, more than its {compressed_len} compressed bytes can hold")
        })?;
    let total = triangles
        .checked_mul(TRIANGLE_BYTES)
        .and_then(|b| b.checked_add(vertex_bytes))
        .filter(|&b| b <= inflate_bound)
        .ok_or_else(|| {
            format!(
                "header claims {triangles} triangles and {vertices} vertices, more than its {compressed_len} compressed bytes can hold"
            )
        })?;
    if total > MAX_MESH_BYTES {
        return Err(format!(
            "{vertices} vertices and {triangles} triangles need {total} bytes, more than the {MAX_MESH_BYTES}-byte limit of one mesh"
        ));
    }
    Ok(())
}

/// Reads the vertex arrays and the triangles; the counts were checked.
fn read_arrays(
    reader: &mut impl BufRead,
    layout: Layout,
    vertices: usize,
    triangles: usize,
) -> Result<MeshData, String> {
    let positions =
        read_vec3s(reader, vertices, layout.double).map_err(stream_error("positions"))?;
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!(
            "vertex {i}: position {} is not finite",
            positions[i]
        ));
    }
    let normals = if layout.normals {
        read_vec3s(reader, vertices, layout.double).map_err(stream_error("normals"))?
    } else {
        Vec::new()
    };
    let uvs = if layout.uvs {
        read_vec2s(reader, vertices, layout.double).map_err(stream_error("texture coordinates"))?
    } else {
        Vec::new()
    };
    if layout.colors {
        // Checked: vertices * 3 * 8 <= MAX_MESH_BYTES.
        let bytes = vertices as u64 * 3 * layout.real_bytes();
        skip_bytes(reader, bytes).map_err(stream_error("vertex colors"))?;
    }
    let triangles = read_triangles(reader, triangles).map_err(stream_error("triangles"))?;
    check_indices(&triangles, vertices)?;
    Ok(MeshData {
        positions,
        normals,
        uvs,
        triangles,
    })
}

/// Checks that every index names a vertex.
fn check_indices(triangles: &[[u32; 3]], vertices: usize) -> Result<(), String> {
    for (i, triangle) in triangles.iter().enumerate() {
        if let Some(&index) = triangle.iter().find(|&&v| v as usize >= vertices) {
            return Err(format!(
                "triangle {i}: vertex index {index} out of range (the mesh has {vertices} vertices)"
            ));
        }
    }
    Ok(())
}

/// Maps a read error of the stream to a message naming what was read.
fn stream_error(what: &'static str) -> impl Fn(io::Error) -> String {
    move |e| {
        if e.kind() == io::ErrorKind::UnexpectedEof {
            format!("zlib stream ends inside the {what}")
        } else {
            format!("corrupt zlib stream in the {what}: {e}")
        }
    }
}

/// Reads past the v4 mesh name, up to and including its NUL byte.
fn skip_name(reader: &mut impl BufRead) -> Result<(), String> {
    let mut skipped = 0u64;
    loop {
        let buffer = reader.fill_buf().map_err(stream_error("mesh name"))?;
        if buffer.is_empty() {
            return Err("zlib stream ends inside the mesh name".into());
        }
        let (used, found) = match buffer.iter().position(|&b| b == 0) {
            Some(nul) => (nul + 1, true),
            None => (buffer.len(), false),
        };
        reader.consume(used);
        skipped += used as u64;
        if skipped > MAX_NAME_BYTES + 1 {
            return Err(format!("mesh name longer than {MAX_NAME_BYTES} bytes"));
        }
        if found {
            return Ok(());
        }
    }
}

/// Reads and drops `bytes` bytes.
fn skip_bytes(reader: &mut impl Read, bytes: u64) -> io::Result<()> {
    let copied = io::copy(&mut reader.take(bytes), &mut io::sink())?;
    if copied < bytes {
        return Err(io::ErrorKind::UnexpectedEof.into());
    }
    Ok(())
}

/// Reads a little-endian `u32`.
fn read_u32(reader: &mut impl Read) -> io::Result<u32> {
    let mut b = [0; 4];
    reader.read_exact(&mut b)?;
    Ok(u32::from_le_bytes(b))
}

/// Reads a little-endian `u64`.
fn read_u64(reader: &mut impl Read) -> io::Result<u64> {
    let mut b = [0; 8];
    reader.read_exact(&mut b)?;
    Ok(u64::from_le_bytes(b))
}

/// Reads `N` reals, `f64` or `f32`, as `f32` (Mitsuba's conversion).
fn read_reals<const N: usize>(reader: &mut impl Read, double: bool) -> io::Result<[f32; N]> {
    let mut out = [0.0; N];
    if double {
        for v in &mut out {
            let mut b = [0; 8];
            reader.read_exact(&mut b)?;
            *v = f64::from_le_bytes(b) as f32;
        }
    } else {
        for v in &mut out {
            let mut b = [0; 4];
            reader.read_exact(&mut b)?;
            *v = f32::from_le_bytes(b);
        }
    }
    Ok(out)
}

/// Reads `n` triples of reals.
fn read_vec3s(reader: &mut impl Read, n: usize, double: bool) -> io::Result<Vec<Vec3>> {
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        out.push(Vec3::from_array(read_reals(reader, double)?));
    }
    Ok(out)
}

/// Reads `n` pairs of reals.
fn read_vec2s(reader: &mut impl Read, n: usize, double: bool) -> io::Result<Vec<Vec2>> {
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        out.push(Vec2::from_array(read_reals(reader, double)?));
    }
    Ok(out)
}

/// Reads `n` triangles of `u32` indices.
fn read_triangles(reader: &mut impl Read, n: usize) -> io::Result<Vec<[u32; 3]>> {
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        out.push([read_u32(reader)?, read_u32(reader)?, read_u32(reader)?]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use flate2::Compression;
    use flate2::write::ZlibEncoder;

    use super::*;

    /// A mesh to encode: values as `f64`, written as the flags say.
    #[derive(Clone, Default)]
    struct Mesh {
        positions: Vec<[f64; 3]>,
        normals: Vec<[f64; 3]>,
        uvs: Vec<[f64; 2]>,
        colors: Vec<[f64; 3]>,
        triangles: Vec<[u32; 3]>,
        double: bool,
    }

    impl Mesh {
        /// A unit square in z = 0, two triangles.
        fn square() -> Self {
            Self {
                positions: vec![
                    [0.0, 0.0, 0.0],
                    [1.0, 0.0, 0.0],
                    [1.0, 1.0, 0.0],
                    [0.0, 1.0, 0.0],
                ],
                triangles: vec![[0, 1, 2], [0, 2, 3]],
                ..Self::default()
            }
        }

        fn with_normals_uvs(mut self) -> Self {
            self.normals = vec![[0.0, 0.0, 1.0]; 4];
            self.uvs = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
            self
        }

        fn flags(&self) -> u32 {
            let mut flags = if self.double { FLAG_DOUBLE } else { 0x1000 };
            for (present, flag) in [
                (!self.normals.is_empty(), FLAG_NORMALS),
                (!self.uvs.is_empty(), FLAG_TEXCOORDS),
                (!self.colors.is_empty(), FLAG_COLORS),
            ] {
                if present {
                    flags |= flag;
                }
            }
            flags
        }

        /// The inflated stream, with the given counts in its header.
        fn stream(&self, version: u16, vertices: u64, triangles: u64) -> Vec<u8> {
            let mut out = self.flags().to_le_bytes().to_vec();
            if version == VERSION_4 {
                out.extend_from_slice(b"square\0");
            }
            out.extend_from_slice(&vertices.to_le_bytes());
            out.extend_from_slice(&triangles.to_le_bytes());
            let reals = self.positions.iter().flatten();
            let reals = reals.chain(self.normals.iter().flatten());
            let reals = reals.chain(self.uvs.iter().flatten());
            for &v in reals.chain(self.colors.iter().flatten()) {
                if self.double {
                    out.extend_from_slice(&v.to_le_bytes());
                } else {
                    out.extend_from_slice(&(v as f32).to_le_bytes());
                }
            }
            for &i in self.triangles.iter().flatten() {
                out.extend_from_slice(&i.to_le_bytes());
            }
            out
        }

        /// Block header and zlib stream.
        fn block(&self, version: u16) -> Vec<u8> {
            let stream = self.stream(
                version,
                self.positions.len() as u64,
                self.triangles.len() as u64,
            );
            block(version, &stream)
        }
    }

    /// A block header and `stream` compressed.
    fn block(version: u16, stream: &[u8]) -> Vec<u8> {
        let mut out = FORMAT_MAGIC.to_le_bytes().to_vec();
        out.extend_from_slice(&version.to_le_bytes());
        let mut encoder = ZlibEncoder::new(out, Compression::default());
        encoder.write_all(stream).unwrap();
        encoder.finish().unwrap()
    }

    /// Blocks concatenated, then the offset table and the count.
    fn file(version: u16, blocks: &[Vec<u8>]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for b in blocks {
            offsets.push(out.len() as u64);
            out.extend_from_slice(b);
        }
        for offset in offsets {
            if version == VERSION_3 {
                out.extend_from_slice(&(offset as u32).to_le_bytes());
            } else {
                out.extend_from_slice(&offset.to_le_bytes());
            }
        }
        out.extend_from_slice(&(blocks.len() as u32).to_le_bytes());
        out
    }

    fn err(bytes: &[u8], shape_index: u32) -> String {
        read(bytes, shape_index).expect_err("the file should be refused")
    }

    #[test]
    fn reads_v3_positions_and_triangles() {
        let mesh = read(&file(VERSION_3, &[Mesh::square().block(VERSION_3)]), 0).unwrap();
        assert_eq!(mesh.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(mesh.normals.is_empty() && mesh.uvs.is_empty());
    }

    #[test]
    fn reads_v4_normals_and_uvs() {
        let bytes = file(
            VERSION_4,
            &[Mesh::square().with_normals_uvs().block(VERSION_4)],
        );
        let mesh = read(&bytes, 0).unwrap();
        assert_eq!(mesh.normals, vec![Vec3::Z; 4]);
        assert_eq!(mesh.uvs[2], Vec2::new(1.0, 1.0));
        assert_eq!(mesh.positions.len(), 4);
    }

    #[test]
    fn reads_f64_reals_and_skips_colors() {
        let mut square = Mesh::square().with_normals_uvs();
        square.double = true;
        square.colors = vec![[0.5, 0.25, 1.0]; 4];
        square.positions[1] = [0.1, 0.0, 0.0];
        let mesh = read(&file(VERSION_4, &[square.block(VERSION_4)]), 0).unwrap();
        assert_eq!(mesh.positions[1], Vec3::new(0.1, 0.0, 0.0));
        assert_eq!(mesh.uvs[3], Vec2::new(0.0, 1.0));
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn shape_index_selects_a_mesh_in_v3_and_v4() {
        let mut moved = Mesh::square();
        moved.positions[0] = [5.0, 6.0, 7.0];
        let mut triangle = Mesh::square().with_normals_uvs();
        triangle.triangles.truncate(1);
        for version in [VERSION_3, VERSION_4] {
            let blocks = [
                Mesh::square().block(version),
                moved.block(version),
                triangle.block(version),
            ];
            let bytes = file(version, &blocks);
            assert_eq!(mesh_count(&bytes), Ok(3));
            assert_eq!(read(&bytes, 0).unwrap().positions[0], Vec3::ZERO);
            assert_eq!(
                read(&bytes, 1).unwrap().positions[0],
                Vec3::new(5.0, 6.0, 7.0)
            );
            let last = read(&bytes, 2).unwrap();
            assert_eq!((last.triangles.len(), last.normals.len()), (1, 4));
        }
    }

    #[test]
    fn shape_index_out_of_range() {
        let bytes = file(
            VERSION_4,
            &[
                Mesh::square().block(VERSION_4),
                Mesh::square().block(VERSION_4),
            ],
        );
        let e = err(&bytes, 2);
        assert_eq!(e, "shape_index 2 out of range: the file holds 2 meshes");
        assert!(err(&bytes, u32::MAX).contains("out of range"));
    }

    #[test]
    fn refuses_a_bad_version_and_magic() {
        let mut bytes = file(VERSION_4, &[Mesh::square().block(VERSION_4)]);
        bytes[2] = 5;
        assert!(
            err(&bytes, 0).contains("unsupported .serialized version 5"),
            "{}",
            err(&bytes, 0)
        );
        bytes[0] = 0;
        assert!(
            err(&bytes, 0).starts_with("not a .serialized file: it starts with 0x0400"),
            "{}",
            err(&bytes, 0)
        );
        assert!(err(&bytes[..3], 0).contains("shorter than the 4-byte header"));
    }

    #[test]
    fn refuses_truncated_data() {
        let bytes = file(
            VERSION_3,
            &[Mesh::square().with_normals_uvs().block(VERSION_3)],
        );
        for cut in [6, 20, 40] {
            let e = err(&bytes[..cut], 0);
            assert!(
                e.starts_with("mesh 0: ") && e.contains("zlib stream"),
                "{cut}: {e}"
            );
        }
        // A whole stream whose header claims one vertex more than it holds.
        let square = Mesh::square();
        let short = block(VERSION_3, &square.stream(VERSION_3, 5, 2));
        let e = err(&file(VERSION_3, &[short]), 0);
        assert!(e.contains("ends inside the triangles"), "{e}");
    }

    #[test]
    fn refuses_a_huge_vertex_count_before_allocating() {
        let square = Mesh::square();
        let stream = square.stream(VERSION_4, 1_000_000_000_000, 2);
        let bytes = file(VERSION_4, &[block(VERSION_4, &stream)]);
        let e = err(&bytes, 0);
        assert!(
            e.starts_with("mesh 0: header claims 1000000000000 vertices, more than its "),
            "{e}"
        );
        assert!(e.ends_with(" compressed bytes can hold"), "{e}");
        // A count whose byte size overflows u64.
        let e = err(
            &file(
                VERSION_4,
                &[block(VERSION_4, &square.stream(VERSION_4, u64::MAX / 4, 2))],
            ),
            0,
        );
        assert!(e.contains("vertices, more than its"), "{e}");
        let e = err(
            &file(
                VERSION_4,
                &[block(VERSION_4, &square.stream(VERSION_4, 4, u64::MAX / 3))],
            ),
            0,
        );
        assert!(e.contains("triangles and 4 vertices, more than its"), "{e}");
    }

    #[test]
    fn caps_a_mesh_that_could_inflate_past_the_limit() {
        // 16 MB of compressed bytes could inflate to 16 GB: the cap speaks first.
        let e = check_counts(500_000_000, 0, Layout::new(0), 16 << 20).unwrap_err();
        assert!(
            e.contains("more than the 4294967296-byte limit of one mesh"),
            "{e}"
        );
    }

    #[test]
    fn refuses_an_index_out_of_range() {
        let mut square = Mesh::square();
        square.triangles[1] = [0, 2, 4];
        let e = err(&file(VERSION_3, &[square.block(VERSION_3)]), 0);
        assert_eq!(
            e,
            "mesh 0: triangle 1: vertex index 4 out of range (the mesh has 4 vertices)"
        );
    }

    #[test]
    fn refuses_non_finite_positions() {
        let mut square = Mesh::square();
        square.double = true;
        square.positions[3] = [0.0, 1e300, 0.0];
        let e = err(&file(VERSION_3, &[square.block(VERSION_3)]), 0);
        assert!(
            e.starts_with("mesh 0: vertex 3: position") && e.ends_with("is not finite"),
            "{e}"
        );
    }

    #[test]
    fn refuses_a_broken_offset_table() {
        let blocks = [
            Mesh::square().block(VERSION_3),
            Mesh::square().block(VERSION_3),
        ];
        let mut bytes = file(VERSION_3, &blocks);
        let n = bytes.len();
        bytes[n - 4..].copy_from_slice(&1_000_000u32.to_le_bytes());
        assert!(err(&bytes, 1).contains("offset table of 1000000 meshes does not fit"));
        // Mesh 0 does not need the table, as in Mitsuba.
        assert!(read(&bytes, 0).is_ok());
        bytes[n - 4..].copy_from_slice(&2u32.to_le_bytes());
        bytes[n - 8..n - 4].copy_from_slice(&7u32.to_le_bytes());
        assert!(
            err(&bytes, 1).contains("no mesh header (0x041c) at byte 7"),
            "{}",
            err(&bytes, 1)
        );
        bytes[n - 8..n - 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(
            err(&bytes, 1).contains("does not end before byte"),
            "{}",
            err(&bytes, 1)
        );
    }

    #[test]
    fn refuses_an_endless_name() {
        let mut stream = 0u32.to_le_bytes().to_vec();
        stream.extend(std::iter::repeat_n(b'a', MAX_NAME_BYTES as usize + 10));
        let e = err(&file(VERSION_4, &[block(VERSION_4, &stream)]), 0);
        assert_eq!(e, "mesh 0: mesh name longer than 65536 bytes");
    }
}
