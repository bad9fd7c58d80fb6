//! Checks of a glTF file's structure before any data is read through the
//! `gltf` crate, whose readers trust the file: a `byteStride` smaller than
//! an element, an index accessor of floats or a TEXCOORD of u32 panic inside
//! it, and an accessor past the end of its buffer silently yields fewer
//! elements. Everything here works on the parsed document and the loaded
//! buffers' actual lengths; every failure names the file, the element
//! (bufferView, accessor with its mesh, primitive and semantic) and the values.

use std::path::Path;

use gltf::accessor::{DataType, Dimensions};

use crate::error::SceneError;

/// Largest `byteStride` the glTF 2.0 spec allows.
pub(super) const MAX_STRIDE: usize = 252;

/// Largest `count` of an accessor without a bufferView: its size is not
/// bounded by any data in the file (a 30-byte JSON edit could ask for
/// billions of zero vertices).
pub(super) const MAX_ZERO_COUNT: usize = 1 << 24;

/// What an accessor feeds, and so which component types and shapes it may have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Semantic {
    /// `POSITION`: FLOAT VEC3.
    Position,
    /// `NORMAL`: FLOAT VEC3.
    Normal,
    /// `TEXCOORD_0`: FLOAT, or normalized UNSIGNED_BYTE/UNSIGNED_SHORT, VEC2.
    TexCoord,
    /// `TANGENT`: FLOAT VEC4.
    Tangent,
    /// `indices`: UNSIGNED_BYTE/SHORT/INT SCALAR.
    Indices,
}

impl Semantic {
    fn name(self) -> &'static str {
        match self {
            Self::Position => "POSITION",
            Self::Normal => "NORMAL",
            Self::TexCoord => "TEXCOORD_0",
            Self::Tangent => "TANGENT",
            Self::Indices => "indices",
        }
    }
}

/// `accessor 3 (mesh 0 primitive 1 POSITION)`: the element of an accessor's errors.
pub(super) fn accessor_label(
    accessor: usize,
    mesh: usize,
    primitive: usize,
    s: Semantic,
) -> String {
    format!(
        "accessor {accessor} (mesh {mesh} primitive {primitive} {})",
        s.name()
    )
}

/// The spec's name of a component type.
pub(super) fn component_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

fn shape_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

/// Every bufferView lies inside its buffer (declared `byteLength` and the
/// bytes actually loaded) and has a legal `byteStride`.
pub(super) fn check_views(
    path: &Path,
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
) -> Result<(), SceneError> {
    for view in document.views() {
        let element = format!("bufferView {}", view.index());
        let invalid = |m: String| SceneError::malformed(path, format!("{element}: {m}"));
        let buffer = view.buffer();
        let available = buffers
            .get(buffer.index())
            .map_or(0, |d| d.0.len())
            .min(buffer.length());
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > available) {
            return Err(invalid(format!(
                "byteOffset {} + byteLength {} exceeds buffer {}'s {available} bytes",
                view.offset(),
                view.length(),
                buffer.index()
            )));
        }
        if let Some(stride) = view.stride()
            && (!(4..=MAX_STRIDE).contains(&stride) || !stride.is_multiple_of(4))
        {
            return Err(invalid(format!(
                "byteStride {stride} is not a multiple of 4 in [4, {MAX_STRIDE}]"
            )));
        }
    }
    Ok(())
}

/// The component type, shape, count and extent of `accessor`, used as `semantic`.
pub(super) fn check_accessor(
    path: &Path,
    label: &str,
    accessor: &gltf::Accessor,
    semantic: Semantic,
    buffers: &[gltf::buffer::Data],
) -> Result<(), SceneError> {
    let fail = |m: String| SceneError::malformed(path, format!("{label}: {m}"));
    let (ty, shape) = (accessor.data_type(), accessor.dimensions());
    let (types_ok, expected_type, expected_shape) = match semantic {
        Semantic::Position | Semantic::Normal => (ty == DataType::F32, "FLOAT", Dimensions::Vec3),
        Semantic::Tangent => (ty == DataType::F32, "FLOAT", Dimensions::Vec4),
        Semantic::TexCoord => (
            ty == DataType::F32
                || (matches!(ty, DataType::U8 | DataType::U16) && accessor.normalized()),
            "FLOAT or normalized UNSIGNED_BYTE/UNSIGNED_SHORT",
            Dimensions::Vec2,
        ),
        Semantic::Indices => (
            matches!(ty, DataType::U8 | DataType::U16 | DataType::U32),
            "UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
            Dimensions::Scalar,
        ),
    };
    if !types_ok {
        let normalized = if accessor.normalized() {
            " (normalized)"
        } else {
            ""
        };
        return Err(fail(format!(
            "component type {}{normalized}, expected {expected_type}",
            component_name(ty)
        )));
    }
    if shape != expected_shape {
        return Err(fail(format!(
            "type {}, expected {}",
            shape_name(shape),
            shape_name(expected_shape)
        )));
    }
    let count = accessor.count();
    if count == 0 {
        return Err(fail("count 0, expected at least 1".into()));
    }
    let component = ty.size();
    let element = accessor.size();
    if !accessor.offset().is_multiple_of(component) {
        return Err(fail(format!(
            "byteOffset {} is not a multiple of the component size {component}",
            accessor.offset()
        )));
    }
    match accessor.view() {
        Some(view) => {
            let stride = view.stride().unwrap_or(element);
            if stride < element {
                return Err(fail(format!(
                    "bufferView {} has byteStride {stride}, smaller than the element size {element}",
                    view.index()
                )));
            }
            let end =
                (count as u128 - 1) * stride as u128 + element as u128 + accessor.offset() as u128;
            if end > view.length() as u128 {
                return Err(fail(format!(
                    "count {count} at byteOffset {} (stride {stride}) needs {end} bytes, bufferView {} has {}",
                    accessor.offset(),
                    view.index(),
                    view.length()
                )));
            }
        }
        None if accessor.sparse().is_none() => {
            return Err(SceneError::unsupported(
                path,
                format!("{label}: no bufferView and no sparse values (all zeros)"),
            ));
        }
        None if count > MAX_ZERO_COUNT => {
            return Err(fail(format!(
                "count {count} without a bufferView (all zeros but the sparse values) exceeds {MAX_ZERO_COUNT}"
            )));
        }
        None => {}
    }
    if let Some(sparse) = accessor.sparse() {
        check_sparse(&fail, accessor, &sparse, buffers)?;
    }
    Ok(())
}

fn check_sparse(
    fail: &dyn Fn(String) -> SceneError,
    accessor: &gltf::Accessor,
    sparse: &gltf::accessor::sparse::Sparse,
    buffers: &[gltf::buffer::Data],
) -> Result<(), SceneError> {
    let count = accessor.count();
    let n = sparse.count();
    if n == 0 || n > count {
        return Err(fail(format!(
            "sparse count {n}, expected 1 to the accessor's count {count}"
        )));
    }
    let indices = sparse.indices();
    let values = sparse.values();
    let index_size = indices.index_type().size();
    for (what, view, offset, size) in [
        (
            "sparse indices",
            indices.view(),
            indices.offset(),
            index_size,
        ),
        (
            "sparse values",
            values.view(),
            values.offset(),
            accessor.size(),
        ),
    ] {
        if view.stride().is_some() {
            return Err(fail(format!(
                "{what}: bufferView {} has a byteStride (not allowed for sparse data)",
                view.index()
            )));
        }
        let end = offset as u128 + n as u128 * size as u128;
        if end > view.length() as u128 {
            return Err(fail(format!(
                "{what}: {n} entries at byteOffset {offset} need {end} bytes, bufferView {} has {}",
                view.index(),
                view.length()
            )));
        }
    }
    // The views were checked against their buffers: the slices exist.
    let view = indices.view();
    let start = view.offset() + indices.offset();
    let bytes = buffers
        .get(view.buffer().index())
        .and_then(|d| d.0.get(start..start + n * index_size))
        .ok_or_else(|| fail("sparse indices: bufferView out of its buffer".into()))?;
    let mut previous: Option<u64> = None;
    for (i, chunk) in bytes.chunks_exact(index_size).enumerate() {
        let index = match index_size {
            1 => u64::from(chunk[0]),
            2 => u64::from(u16::from_le_bytes([chunk[0], chunk[1]])),
            _ => u64::from(u32::from_le_bytes([chunk[0], chunk[1], chunk[2], chunk[3]])),
        };
        if index >= count as u64 {
            return Err(fail(format!(
                "sparse index {i} is {index}, past the accessor's count {count}"
            )));
        }
        if previous.is_some_and(|p| index <= p) {
            return Err(fail(format!(
                "sparse index {i} is {index}, not greater than the previous one (must increase)"
            )));
        }
        previous = Some(index);
    }
    Ok(())
}
