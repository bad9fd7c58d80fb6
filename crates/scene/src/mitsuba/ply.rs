//! PLY meshes (`.ply`), the subset Mitsuba 3.9.1 reads
//! (`src/shapes/ply.cpp`; `shared/notes/mitsuba-format.md`, section 7),
//! parsed by the `ply-rs-bw` crate behind guards of our own.
//!
//! Subset: `ascii`, `binary_little_endian` and `binary_big_endian`; a
//! `vertex` element with `x y z` (any scalar type, converted to `f32`),
//! normals `nx ny nz` when all three are present, texture coordinates
//! `u v`, `texture_u texture_v` or `s t` (the first pair present, in that
//! order); a `face` element whose list `vertex_indices` (or
//! `vertex_index`) holds exactly three indices per face: Mitsuba refuses
//! quads and polygons, and so do we, naming the face. Other properties and
//! elements are read past. As in Mitsuba, a header line other than
//! `format`, `element`, `property`, `comment` and `end_header` (such as
//! `obj_info`) is an error, and so are bytes after the last element
//! (whitespace excepted in ASCII files).
//!
//! What the crate does with hostile input, and the guards (tested by the
//! unit tests below and the `ply` fuzz target): it preallocates at most
//! 65,536 records per element whatever the header claims and grows as
//! records arrive, so a huge count alone allocates nothing; but it loops
//! `count` times over an element, so a binary element without properties
//! claiming 10^12 records would run (and, with its default element type,
//! allocate) for ever. It keys elements and properties by name, so a
//! duplicate silently replaces the first and the records are misread, and
//! it accepts `obj_info` lines, which Mitsuba refuses. Its errors quote
//! whole lines over several lines. So, before the crate reads anything,
//! `check_header_lines` refuses duplicates and the lines Mitsuba
//! refuses; after it has parsed the header and before it reads a record,
//! `check_sizes` checks every element's count against the bytes after
//! the header (`min_record_bytes`); binary elements without properties
//! are not handed to it at all (they occupy no bytes). Records go into our
//! own small types (`Vertex`, 32 bytes, `Face`, 24 bytes), not the
//! crate's map per record, so memory stays within about 24 times the
//! file's size (a face record takes one byte at least). Then every face
//! must be a triangle, indices must name a vertex and positions must be
//! finite. Errors are one line, the crate's cut to `MAX_ERROR_CHARS`.

use std::collections::HashSet;

use glam::{Vec2, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    ElementDef, Encoding, Header, KeyMap, PropertyAccess, PropertyAccessResult, PropertyDef,
    PropertyType, ScalarType,
};

use super::MeshData;
use crate::error::quoted;

/// Bytes an ASCII property takes at least: one digit and a separator
/// (a space, or the newline after the last one).
const ASCII_MIN_PROPERTY_BYTES: u64 = 2;

/// Bytes an ASCII record without properties takes at least: its newline.
const ASCII_MIN_EMPTY_RECORD_BYTES: u64 = 1;

/// Bytes the last ASCII record may lack: its final newline.
const ASCII_MISSING_FINAL_NEWLINE: u64 = 1;

/// Longest crate error kept, in characters: the crate quotes whole data
/// lines, and an error must stay one readable line.
const MAX_ERROR_CHARS: usize = 240;

/// Vertex properties read as positions, in order.
const POSITION_NAMES: [&str; 3] = ["x", "y", "z"];

/// Vertex properties read as normals, used only when all three are present.
const NORMAL_NAMES: [&str; 3] = ["nx", "ny", "nz"];

/// Pairs of vertex properties read as texture coordinates: the first pair
/// present is used.
const UV_NAMES: [[&str; 2]; 3] = [["u", "v"], ["texture_u", "texture_v"], ["s", "t"]];

/// Scalar types Mitsuba reads that ply-rs-bw does not.
const UNSUPPORTED_TYPES: [&str; 4] = ["long", "ulong", "half", "float16"];

/// Names of the face list of vertex indices: the first present is used.
const FACE_LIST_NAMES: [&str; 2] = ["vertex_indices", "vertex_index"];

/// Key under which the chosen face list is handed to [`Face`].
const FACE_LIST_ROLE: &str = "vertex_indices";

/// Reads a PLY file into a triangle mesh.
pub fn read(bytes: &[u8]) -> Result<MeshData, String> {
    check_header_lines(bytes)?;
    let mut reader = Reader::new(bytes);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| one_line(&e.to_string()))?;
    let payload_len = reader.get_ref().len();
    check_sizes(&header, payload_len as u64)?;
    let plan = Plan::new(&header)?;

    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for element in header.elements.values() {
        match (element.name.as_str(), &plan.face) {
            ("vertex", _) => vertices = read_records(&mut reader, &plan.vertex, &header)?,
            ("face", Some(face)) => faces = read_records(&mut reader, face, &header)?,
            // A binary element without properties occupies no bytes.
            _ if element.properties.is_empty() && header.encoding != Encoding::Ascii => {}
            _ => {
                read_records::<Skip>(&mut reader, element, &header)?;
            }
        }
    }
    check_trailing_bytes(reader.get_ref(), header.encoding)?;
    mesh(&plan, &vertices, &faces)
}

/// Reads all records of `element` with the crate.
fn read_records<E: PropertyAccess>(
    reader: &mut Reader<&[u8]>,
    element: &ElementDef,
    header: &Header,
) -> Result<Vec<E>, String> {
    Parser::<E>::new()
        .read_payload_for_element(reader, element, header)
        .map_err(|e| {
            format!(
                "element {}: {}",
                quoted(&element.name),
                one_line(&e.to_string())
            )
        })
}

/// A crate error on one line, cut to [`MAX_ERROR_CHARS`].
fn one_line(message: &str) -> String {
    let line = message.split_whitespace().collect::<Vec<_>>().join(" ");
    match line.char_indices().nth(MAX_ERROR_CHARS) {
        Some((cut, _)) => format!("{}...", &line[..cut]),
        None => line,
    }
}

/// Checks the header lines, up to `end_header`, for what the crate accepts
/// but Mitsuba, or a correct reading, does not: lines other than `ply`,
/// `format`, `comment`, `element`, `property` and `end_header`, and
/// duplicate element or property names (the crate would keep one); and
/// names the types Mitsuba reads but the crate does not
/// ([`UNSUPPORTED_TYPES`]), which the crate would report as a syntax error.
fn check_header_lines(bytes: &[u8]) -> Result<(), String> {
    let mut elements = HashSet::new();
    let mut properties = HashSet::new();
    let mut element = String::new();
    let first = bytes.split(|&b| b == b'\n').next().unwrap_or_default();
    if first.trim_ascii() != b"ply" {
        return Err(format!(
            "not a PLY file: it starts with {}, not \"ply\"",
            quoted(&String::from_utf8_lossy(first))
        ));
    }
    for line in bytes.split(|&b| b == b'\n') {
        let line = String::from_utf8_lossy(line);
        let mut tokens = line.split_ascii_whitespace();
        match tokens.next() {
            Some("end_header") => break,
            Some("element") => {
                element = tokens.next().unwrap_or_default().to_string();
                if !elements.insert(element.clone()) {
                    return Err(format!("header: duplicate element {}", quoted(&element)));
                }
                properties.clear();
            }
            Some("property") => {
                let tokens: Vec<&str> = tokens.collect();
                if let Some(t) = tokens.iter().find(|t| UNSUPPORTED_TYPES.contains(t)) {
                    return Err(format!(
                        "header line {}: type {t} is not supported (this reader takes 8- to 32-bit integers, float and double)",
                        quoted(&line)
                    ));
                }
                let name = tokens.last().copied().unwrap_or_default();
                if !properties.insert(name.to_string()) {
                    return Err(format!(
                        "header: element {} has two properties {}",
                        quoted(&element),
                        quoted(name)
                    ));
                }
            }
            Some("ply" | "format" | "comment") | None => {}
            Some(_) => {
                return Err(format!(
                    "header line {} not allowed: Mitsuba 3 reads only format, element, property and comment lines",
                    quoted(line.trim())
                ));
            }
        }
    }
    Ok(())
}

/// Checks that the records every element claims fit in the `payload`
/// bytes after the header, before any record is read.
fn check_sizes(header: &Header, payload: u64) -> Result<(), String> {
    let available = match header.encoding {
        Encoding::Ascii => payload + ASCII_MISSING_FINAL_NEWLINE,
        Encoding::BinaryBigEndian | Encoding::BinaryLittleEndian => payload,
    };
    let mut needed = 0u64;
    for element in header.elements.values() {
        let count = element.count as u64;
        needed = count
            .checked_mul(min_record_bytes(element, header.encoding))
            .and_then(|bytes| bytes.checked_add(needed))
            .filter(|&bytes| bytes <= available)
            .ok_or_else(|| {
                format!(
                    "element {} claims {count} records, more than the {payload} bytes after the header can hold",
                    quoted(&element.name)
                )
            })?;
    }
    Ok(())
}

/// Fewest bytes one record of `element` takes in the file: the sum of its
/// scalars' sizes and lists' length fields (lists may be empty) in binary,
/// [`ASCII_MIN_PROPERTY_BYTES`] per property in ASCII.
fn min_record_bytes(element: &ElementDef, encoding: Encoding) -> u64 {
    if encoding == Encoding::Ascii {
        let properties = element.properties.len() as u64;
        return (properties * ASCII_MIN_PROPERTY_BYTES).max(ASCII_MIN_EMPTY_RECORD_BYTES);
    }
    element
        .properties
        .values()
        .map(|p| match &p.data_type {
            PropertyType::Scalar(t) | PropertyType::List(t, _) => scalar_bytes(t),
        })
        .sum()
}

/// Bytes of a binary scalar.
fn scalar_bytes(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// Refuses bytes after the last element, as Mitsuba does; an ASCII file
/// may end in whitespace.
fn check_trailing_bytes(rest: &[u8], encoding: Encoding) -> Result<(), String> {
    let extra = match encoding {
        Encoding::Ascii => rest.trim_ascii().len(),
        Encoding::BinaryBigEndian | Encoding::BinaryLittleEndian => rest.len(),
    };
    if extra > 0 {
        return Err(format!("{extra} bytes after the last element"));
    }
    Ok(())
}

/// The `vertex` and `face` elements as handed to the crate: each property
/// keyed by the role it plays ([`Vertex`] and [`Face`] read roles), the
/// others by keys no setter knows.
struct Plan {
    /// The vertex element, with roles `x y z`, `nx ny nz`, `u v`.
    vertex: ElementDef,
    /// Normals are present.
    normals: bool,
    /// Texture coordinates are present.
    uvs: bool,
    /// The face element, its index list keyed [`FACE_LIST_ROLE`]; `None`
    /// if the file has no faces.
    face: Option<ElementDef>,
}

impl Plan {
    /// Chooses the properties to read and checks their types.
    fn new(header: &Header) -> Result<Self, String> {
        let vertex = header
            .elements
            .get("vertex")
            .ok_or("no \"vertex\" element")?;
        for name in POSITION_NAMES {
            match vertex.properties.get(name).map(|p| &p.data_type) {
                Some(PropertyType::Scalar(_)) => {}
                Some(PropertyType::List(..)) => {
                    return Err(format!("vertex property {} is a list", quoted(name)));
                }
                None => return Err(format!("vertex property {} is missing", quoted(name))),
            }
        }
        let scalar = |name: &str| {
            matches!(
                vertex.properties.get(name).map(|p| &p.data_type),
                Some(PropertyType::Scalar(_))
            )
        };
        let normals = NORMAL_NAMES.iter().all(|n| scalar(n));
        let uv = UV_NAMES.iter().find(|pair| pair.iter().all(|n| scalar(n)));
        let mut roles: Vec<(&str, &str)> = POSITION_NAMES.iter().map(|n| (*n, *n)).collect();
        if normals {
            roles.extend(NORMAL_NAMES.iter().map(|n| (*n, *n)));
        }
        if let Some([u, v]) = uv {
            roles.extend([(*u, "u"), (*v, "v")]);
        }
        let face = match header.elements.get("face") {
            Some(face) => Some(face_plan(face)?),
            None => None,
        };
        Ok(Self {
            vertex: with_roles(vertex, &roles),
            normals,
            uvs: uv.is_some(),
            face,
        })
    }
}

/// The face element with its index list keyed [`FACE_LIST_ROLE`], after
/// checking it is a list of integers.
fn face_plan(face: &ElementDef) -> Result<ElementDef, String> {
    let Some(name) = FACE_LIST_NAMES
        .into_iter()
        .find(|n| face.properties.contains_key(*n))
    else {
        return Err("face element has no \"vertex_indices\" or \"vertex_index\" list".into());
    };
    match &face.properties[name].data_type {
        PropertyType::List(_, ScalarType::Float | ScalarType::Double) => Err(format!(
            "face property {} holds reals, not vertex indices",
            quoted(name)
        )),
        PropertyType::List(..) => Ok(with_roles(face, &[(name, FACE_LIST_ROLE)])),
        PropertyType::Scalar(_) => Err(format!("face property {} is not a list", quoted(name))),
    }
}

/// `element` with the properties named in `roles` keyed by their role and
/// the others by a key no setter knows (it holds a space, which a PLY
/// name cannot), in the file's order.
fn with_roles(element: &ElementDef, roles: &[(&str, &str)]) -> ElementDef {
    let mut properties = KeyMap::new();
    for (i, (name, property)) in element.properties.iter().enumerate() {
        let key = roles
            .iter()
            .find(|(n, _)| n == name)
            .map_or_else(|| format!("unused {i}"), |(_, role)| (*role).to_string());
        properties.insert(
            key.clone(),
            PropertyDef::new(key, property.data_type.clone()),
        );
    }
    ElementDef {
        name: element.name.clone(),
        count: element.count,
        properties,
    }
}

/// Builds the mesh from the records, checking positions and indices.
fn mesh(plan: &Plan, vertices: &[Vertex], faces: &[Face]) -> Result<MeshData, String> {
    let positions: Vec<Vec3> = vertices
        .iter()
        .map(|v| Vec3::from_array(v.position))
        .collect();
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!(
            "vertex {i}: position {} is not finite",
            positions[i]
        ));
    }
    let normals = if plan.normals {
        vertices
            .iter()
            .map(|v| Vec3::from_array(v.normal))
            .collect()
    } else {
        Vec::new()
    };
    let uvs = if plan.uvs {
        vertices.iter().map(|v| Vec2::from_array(v.uv)).collect()
    } else {
        Vec::new()
    };
    let triangles = faces
        .iter()
        .enumerate()
        .map(|(i, face)| {
            face.triangle(vertices.len())
                .map_err(|e| format!("face {i}: {e}"))
        })
        .collect::<Result<_, _>>()?;
    Ok(MeshData {
        positions,
        normals,
        uvs,
        triangles,
    })
}

/// One vertex record: the roles of [`Plan::vertex`].
#[derive(Clone, Copy, Debug, Default)]
struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
}

impl Vertex {
    /// Stores `value` under its role; other keys are ignored.
    fn set(&mut self, role: &str, value: f32) -> PropertyAccessResult {
        let slot = match role {
            "x" => &mut self.position[0],
            "y" => &mut self.position[1],
            "z" => &mut self.position[2],
            "nx" => &mut self.normal[0],
            "ny" => &mut self.normal[1],
            "nz" => &mut self.normal[2],
            "u" => &mut self.uv[0],
            "v" => &mut self.uv[1],
            _ => return PropertyAccessResult::Ignored,
        };
        *slot = value;
        PropertyAccessResult::Set
    }
}

/// Scalars of any type become `f32`, as in Mitsuba.
impl PropertyAccess for Vertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_char(&mut self, name: &str, value: i8) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_uchar(&mut self, name: &str, value: u8) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        self.set(name, value as f32)
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        self.set(name, value as f32)
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        self.set(name, value)
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        self.set(name, value as f32)
    }
}

/// One face record: the first three indices of its list, the list's
/// length and whether an index was negative.
#[derive(Clone, Copy, Debug, Default)]
struct Face {
    indices: [u32; 3],
    len: usize,
    negative: bool,
}

impl Face {
    /// Keeps the list under [`FACE_LIST_ROLE`]; other lists are ignored.
    fn set<T: Copy + TryInto<u32>>(&mut self, role: &str, values: &[T]) -> PropertyAccessResult {
        if role != FACE_LIST_ROLE {
            return PropertyAccessResult::Ignored;
        }
        self.len = values.len();
        for (slot, &value) in self.indices.iter_mut().zip(values) {
            match value.try_into() {
                Ok(index) => *slot = index,
                Err(_) => self.negative = true,
            }
        }
        PropertyAccessResult::Set
    }

    /// The triangle, if the face is one and its indices name vertices.
    fn triangle(&self, vertices: usize) -> Result<[u32; 3], String> {
        if self.len != 3 {
            return Err(format!(
                "{} vertices; Mitsuba 3 reads triangles only",
                self.len
            ));
        }
        if self.negative {
            return Err("negative vertex index".into());
        }
        match self.indices.iter().find(|&&i| i as usize >= vertices) {
            Some(i) => Err(format!(
                "vertex index {i} out of range (the file has {vertices} vertices)"
            )),
            None => Ok(self.indices),
        }
    }
}

/// Integer lists of any type; [`face_plan`] refuses real lists before
/// reading.
impl PropertyAccess for Face {
    fn new() -> Self {
        Self::default()
    }
    fn set_list_char(&mut self, name: &str, value: Vec<i8>) -> PropertyAccessResult {
        self.set(name, &value)
    }
    fn set_list_uchar(&mut self, name: &str, value: Vec<u8>) -> PropertyAccessResult {
        self.set(name, &value)
    }
    fn set_list_short(&mut self, name: &str, value: Vec<i16>) -> PropertyAccessResult {
        self.set(name, &value)
    }
    fn set_list_ushort(&mut self, name: &str, value: Vec<u16>) -> PropertyAccessResult {
        self.set(name, &value)
    }
    fn set_list_int(&mut self, name: &str, value: Vec<i32>) -> PropertyAccessResult {
        self.set(name, &value)
    }
    fn set_list_uint(&mut self, name: &str, value: Vec<u32>) -> PropertyAccessResult {
        self.set(name, &value)
    }
}

/// A record of an element we read past: every property is ignored (the
/// trait's default setters), nothing is stored.
#[derive(Clone, Copy, Debug)]
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square: positions, normals, uvs, two triangles.
    const SQUARE: [[f32; 8]; 4] = [
        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
        [1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0],
    ];
    const TRIANGLES: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

    fn err(bytes: &[u8]) -> String {
        let e = read(bytes).expect_err("the file should be refused");
        assert!(!e.contains('\n'), "not one line: {e}");
        e
    }

    /// An ASCII square: `vertex` with `props` (a header fragment) and the
    /// rows, and `face` with `faces` rows.
    fn ascii(props: &str, rows: &[&str], faces: &[&str]) -> Vec<u8> {
        let mut text = format!(
            "ply\nformat ascii 1.0\ncomment made by a test\nelement vertex {}\n{props}element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            rows.len(),
            faces.len()
        );
        for line in rows.iter().chain(faces) {
            text.push_str(line);
            text.push('\n');
        }
        text.into_bytes()
    }

    const XYZ: &str = "property float x\nproperty float y\nproperty float z\n";

    fn square_ascii_rows() -> Vec<String> {
        SQUARE
            .iter()
            .map(|v| v.map(|x| x.to_string()).join(" ") + " 255")
            .collect()
    }

    #[test]
    fn reads_ascii_with_normals_uvs_and_ignored_data() {
        let props = format!(
            "{XYZ}property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nproperty uchar red\n"
        );
        let rows = square_ascii_rows();
        let rows: Vec<&str> = rows.iter().map(String::as_str).collect();
        let mut bytes = ascii(&props, &rows, &["3 0 1 2", "3 0 2 3"]);
        bytes.extend_from_slice(b"\n\n");
        let mesh = read(&bytes).unwrap();
        assert_eq!(mesh.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(mesh.normals, vec![Vec3::Z; 4]);
        assert_eq!(mesh.uvs[1], Vec2::new(1.0, 0.0));
        assert_eq!(mesh.triangles, TRIANGLES.to_vec());
    }

    #[test]
    fn reads_s_t_and_needs_all_three_normals() {
        let props = format!(
            "{XYZ}property float nx\nproperty float ny\nproperty float s\nproperty float t\n"
        );
        let rows = ["0 0 0 1 1 0.25 0.5", "1 0 0 1 1 0 0", "0 1 0 1 1 0 0"];
        let mesh = read(&ascii(&props, &rows, &["3 0 1 2"])).unwrap();
        assert!(mesh.normals.is_empty());
        assert_eq!(mesh.uvs[0], Vec2::new(0.25, 0.5));
    }

    #[test]
    fn reads_integer_positions_and_vertex_index() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty int x\nproperty short y\nproperty uchar z\nelement face 1\nproperty list uchar uint vertex_index\nend_header\n-2 0 0\n1 0 0\n0 1 9\n3 2 1 0";
        let mesh = read(text.as_bytes()).unwrap();
        assert_eq!(mesh.positions[0], Vec3::new(-2.0, 0.0, 0.0));
        assert_eq!(mesh.positions[2], Vec3::new(0.0, 1.0, 9.0));
        assert_eq!(mesh.triangles, vec![[2, 1, 0]]);
    }

    /// A binary square with `double` positions, `texture_u texture_v`,
    /// normals, an element of edges before the faces and an element
    /// without properties.
    fn binary(big_endian: bool) -> Vec<u8> {
        let format = if big_endian {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        };
        let mut out = format!(
            "ply\nformat {format} 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float texture_u\nproperty float texture_v\nelement edge 1\nproperty int a\nproperty list uchar int b\nelement nothing 1000000000000\nelement face 2\nproperty uchar flags\nproperty list uchar int vertex_indices\nend_header\n"
        )
        .into_bytes();
        let f32s = |out: &mut Vec<u8>, v: f32| {
            out.extend_from_slice(&if big_endian {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            })
        };
        let i32s = |out: &mut Vec<u8>, v: i32| {
            out.extend_from_slice(&if big_endian {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            })
        };
        for v in SQUARE {
            for x in &v[..3] {
                let x = f64::from(*x);
                out.extend_from_slice(&if big_endian {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }
            for x in &v[3..] {
                f32s(&mut out, *x);
            }
        }
        i32s(&mut out, 7);
        out.push(2);
        i32s(&mut out, 1);
        i32s(&mut out, 2);
        for t in TRIANGLES {
            out.extend_from_slice(&[0, 3]);
            for i in t {
                i32s(&mut out, i as i32);
            }
        }
        out
    }

    #[test]
    fn reads_binary_little_and_big_endian() {
        for big_endian in [false, true] {
            let mesh = read(&binary(big_endian)).unwrap();
            assert_eq!(mesh.positions[1], Vec3::new(1.0, 0.0, 0.0), "{big_endian}");
            assert_eq!(mesh.normals[3], Vec3::Z);
            assert_eq!(mesh.uvs[2], Vec2::new(1.0, 1.0));
            assert_eq!(mesh.triangles, TRIANGLES.to_vec());
        }
    }

    #[test]
    fn refuses_a_quad() {
        let rows = ["0 0 0", "1 0 0", "1 1 0", "0 1 0"];
        let e = err(&ascii(XYZ, &rows, &["3 0 1 2", "4 0 1 2 3"]));
        assert_eq!(e, "face 1: 4 vertices; Mitsuba 3 reads triangles only");
    }

    #[test]
    fn refuses_an_index_out_of_range_or_negative() {
        let rows = ["0 0 0", "1 0 0", "1 1 0"];
        let e = err(&ascii(XYZ, &rows, &["3 0 1 2", "3 0 1 3"]));
        assert_eq!(
            e,
            "face 1: vertex index 3 out of range (the file has 3 vertices)"
        );
        let e = err(&ascii(XYZ, &rows, &["3 0 -1 2"]));
        assert_eq!(e, "face 0: negative vertex index");
    }

    #[test]
    fn refuses_a_huge_vertex_count_before_reading() {
        let text = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n0123456789ab";
        let e = err(text.as_bytes());
        assert_eq!(
            e,
            "element \"vertex\" claims 1000000000000 records, more than the 12 bytes after the header can hold"
        );
        let ascii = text.replace("binary_little_endian", "ascii");
        assert!(
            err(ascii.as_bytes()).starts_with("element \"vertex\" claims 1000000000000 records")
        );
        let ascii = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement junk 1000000000000\nend_header\n0 0 0\n";
        assert!(err(ascii.as_bytes()).starts_with("element \"junk\" claims 1000000000000 records"));
        let overflow = "ply\nformat binary_big_endian 1.0\nelement vertex 18446744073709551615\nproperty double x\nend_header\n";
        assert!(err(overflow.as_bytes()).contains("claims 18446744073709551615 records"));
    }

    #[test]
    fn refuses_truncated_data() {
        let bytes = binary(false);
        let e = err(&bytes[..bytes.len() - 5]);
        assert!(e.starts_with("element \"face\": "), "{e}");
        let e = err(&bytes[..bytes.len() - 60]);
        assert!(e.contains("bytes after the header can hold"), "{e}");
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 3\n");
        assert!(e.contains("end of file"), "{e}");
    }

    #[test]
    fn refuses_trailing_bytes() {
        let mut bytes = binary(true);
        bytes.push(0);
        assert_eq!(err(&bytes), "1 bytes after the last element");
        let rows = ["0 0 0", "1 0 0", "1 1 0"];
        let mut bytes = ascii(XYZ, &rows, &["3 0 1 2"]);
        bytes.extend_from_slice(b"3 0 1 2\n");
        assert_eq!(err(&bytes), "7 bytes after the last element");
    }

    #[test]
    fn refuses_headers_mitsuba_refuses_or_the_crate_misreads() {
        let rows = ["0 0 0", "1 0 0", "1 1 0"];
        let with = |extra: &str| {
            String::from_utf8(ascii(XYZ, &rows, &["3 0 1 2"]))
                .unwrap()
                .replacen("comment", extra, 1)
        };
        let e = err(with("obj_info made by a test\ncomment").as_bytes());
        assert!(
            e.starts_with("header line \"obj_info made by a test\" not allowed"),
            "{e}"
        );
        let e = err(with("element vertex 0\ncomment").as_bytes());
        assert_eq!(e, "header: duplicate element \"vertex\"");
        let props = format!("{XYZ}property float x\n");
        let e = err(&ascii(&props, &["0 0 0 0"], &[]));
        assert_eq!(e, "header: element \"vertex\" has two properties \"x\"");
        assert!(
            err(b"ply\nformat ascii 1.0\nproperty float x\nend_header\n")
                .contains("without preceding element")
        );
        assert_eq!(
            err(b"PLY\n"),
            "not a PLY file: it starts with \"PLY\", not \"ply\""
        );
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty half x\nend_header\n");
        assert!(
            e.starts_with("header line \"property half x\": type half is not supported"),
            "{e}"
        );
    }

    #[test]
    fn refuses_missing_or_mistyped_properties() {
        let e = err(&ascii(
            "property float x\nproperty float z\n",
            &["0 0"],
            &[],
        ));
        assert_eq!(e, "vertex property \"y\" is missing");
        let text =
            String::from_utf8(ascii(XYZ, &["0 0 0", "1 0 0", "1 1 0"], &["3 0 1 2"])).unwrap();
        let e = err(text
            .replace("uchar int vertex_indices", "uchar float vertex_indices")
            .as_bytes());
        assert_eq!(
            e,
            "face property \"vertex_indices\" holds reals, not vertex indices"
        );
        let e = err(text
            .replace("list uchar int vertex_indices", "int flags")
            .as_bytes());
        assert!(e.contains("no \"vertex_indices\""), "{e}");
        assert_eq!(
            err(b"ply\nformat ascii 1.0\nend_header\n"),
            "no \"vertex\" element"
        );
    }

    #[test]
    fn refuses_non_finite_positions_and_bad_numbers() {
        let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty float y\nproperty float z\nend_header\n1e300 0 0\n";
        assert_eq!(
            err(text.as_bytes()),
            "vertex 0: position [inf, 0, 0] is not finite"
        );
        let e = err(text.replace("1e300", "abc").as_bytes());
        assert!(e.starts_with("element \"vertex\": "), "{e}");
    }
}
