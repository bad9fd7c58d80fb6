//! Wavefront OBJ/MTL loading with `tobj` (mapping: see `material` module docs).
//!
//! The file is streamed, never held whole: one pass checks its values
//! (`check_lines`), then tobj parses it through `Chunked`, which cuts
//! long runs of faces into models of at most `CHUNK_TRIANGLES`
//! triangles (tobj keeps 104 bytes per face of the model it is reading),
//! and the models go into the scene one by one, each freed once copied.
//! A 999,698-triangle height field peaked at about 200 bytes per triangle
//! in this loader when it read the whole text and gave it to tobj at once;
//! streamed, the process peaks at 97 MB resident while loading it (by our
//! count mostly the edge map of `SceneBuilder::finish`, 61 MB, beside the
//! scene's 23 MB).

use std::cell::RefCell;
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use microfacet::{Fresnel, MicrofacetModel, NdfKind, Shadowing};

use crate::error::{SceneError, quoted};
use crate::material::{
    Maps, Material, MetalRough, NormalMap, NormalMapKind, Surface, TexturedPbr, metal_rough_surface,
};
use crate::scene::SceneBuilder;
use crate::texture::Texture;

/// Materials with a dissolve `d` below this are transparent (glass-like).
const OPAQUE_DISSOLVE: f32 = 0.999;

/// Index of the coat of an MTL material with Ks (see the `material` module
/// docs): only the F0 that the specular colour scales depends on it.
const MTL_COAT_IOR: f32 = 1.5;

/// F0 = ((ior - 1)/(ior + 1))^2 of `MTL_COAT_IOR` (Fresnel at normal
/// incidence, 0.04), as `microfacet::Coated::dielectric_f0` computes it.
const MTL_COAT_F0: f32 = {
    let r = (MTL_COAT_IOR - 1.0) / (MTL_COAT_IOR + 1.0);
    r * r
};

/// Triangles of faces tobj holds at most, give or take one model's worth,
/// before it exports them as a model ([`Chunked`]): 6.8 MB of its 104-byte
/// face records, the same for any file size.
const CHUNK_TRIANGLES: usize = 1 << 16;

/// Read buffer of the OBJ file's passes.
const READ_BUFFER: usize = 1 << 16;

/// Material of faces without `usemtl`.
pub(crate) fn default_material() -> Material {
    Material {
        name: "default".into(),
        surface: Surface::Diffuse {
            reflectance: Vec3::splat(0.8),
        },
        emission: Vec3::ZERO,
        medium: None,
        maps: Default::default(),
    }
}

/// Textures loaded so far, by file and colour space (a file used both as a
/// colour and as a scalar map is decoded twice).
type TextureCache = HashMap<(PathBuf, bool), usize>;

/// Where each material came from: its MTL file and the line of its `newmtl`.
type Origins = HashMap<String, (PathBuf, usize)>;

/// Loads an OBJ file and the MTL files it references (resolved with `policy`).
pub fn load(
    path: &Path,
    policy: &crate::paths::ReferencePolicy,
) -> Result<SceneBuilder, SceneError> {
    let ChecksPassed {
        usemtl,
        vertices,
        triangles,
    } = check_lines(path)?;
    // The scene's arrays at their final size before tobj runs, so that
    // they never move while growing past tobj's freed buffers (glibc then
    // keeps the holes: 29 MB of a million-triangle load was such).
    let mut builder = SceneBuilder::default();
    builder.reserve(triangles, vertices);
    let Parsed {
        models,
        materials,
        origins,
        splits,
    } = parse(path, policy)?;
    warn_undefined_usemtl(path, usemtl, &materials, &mut builder);
    let material_ids = add_materials(path, policy, &materials, &origins, &mut builder)?;
    add_models(path, models, &splits, &material_ids, &mut builder)?;
    Ok(builder)
}

/// What tobj made of the OBJ file and its MTL files.
struct Parsed {
    /// The file's objects and groups, long runs of faces cut into several by [`Chunked`].
    models: Vec<tobj::Model>,
    /// The materials of every MTL file, in tobj's order.
    materials: Vec<tobj::Material>,
    /// Where each material was defined.
    origins: Origins,
    /// The number of triangles read before each cut [`Chunked`] made, increasing.
    splits: Vec<usize>,
}

/// Parses the OBJ file with tobj, streamed through [`Chunked`], and its MTL
/// files with [`load_mtl`]. An MTL file's own error is returned as it is:
/// tobj's material loader can only say that one failed.
fn parse(path: &Path, policy: &crate::paths::ReferencePolicy) -> Result<Parsed, SceneError> {
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // tobj's material loader cannot return our error: keep the first one here.
    let mtl_error: RefCell<Option<SceneError>> = RefCell::new(None);
    let origins: RefCell<Origins> = RefCell::new(HashMap::new());
    let loader = |reference: &Path| -> tobj::MTLLoadResult {
        match load_mtl(path, reference, policy) {
            Ok(LoadedMtl {
                file,
                materials,
                lines,
            }) => {
                let mut origins = origins.borrow_mut();
                for (name, line) in lines {
                    origins.entry(name).or_insert((file.clone(), line));
                }
                Ok(materials)
            }
            Err(e) => {
                mtl_error.borrow_mut().get_or_insert(e);
                Err(tobj::LoadError::OpenFileFailed)
            }
        }
    };
    let file = File::open(path).map_err(|e| SceneError::io(path, e))?;
    let mut reader = Chunked::new(BufReader::with_capacity(READ_BUFFER, file));
    let loaded = tobj::load_obj_buf(&mut reader, &options, loader);
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    if let Some(e) = reader.error.take() {
        return Err(SceneError::io(path, e));
    }
    let (models, materials) = loaded.map_err(|e| SceneError::malformed(path, describe(&e)))?;
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            return Err(SceneError::malformed(
                path,
                format!(
                    "its material library (mtllib) failed to load: {}",
                    describe(&e)
                ),
            ));
        }
    };
    Ok(Parsed {
        models,
        materials,
        origins: origins.into_inner(),
        splits: reader.splits,
    })
}

/// Warns of each `usemtl` (at its first line) that names no material of
/// the MTL files: its faces get the default material.
fn warn_undefined_usemtl(
    path: &Path,
    usemtl: Vec<(usize, String)>,
    materials: &[tobj::Material],
    builder: &mut SceneBuilder,
) {
    for (line, name) in usemtl
        .into_iter()
        .filter(|(_, name)| !materials.iter().any(|m| m.name == *name))
    {
        builder.report.warnings.push(format!(
            "{}: line {line}: usemtl {} names no material of its MTL files: the default \
             material (diffuse 0.8) is used",
            path.display(),
            quoted(&name)
        ));
    }
}

/// Adds the MTL materials to the scene ([`map_material`]), each naming in
/// its errors the MTL file and `newmtl` line it came from (the OBJ file and
/// no line if unknown). Returns their scene ids, in tobj's order.
fn add_materials(
    path: &Path,
    policy: &crate::paths::ReferencePolicy,
    materials: &[tobj::Material],
    origins: &Origins,
    builder: &mut SceneBuilder,
) -> Result<Vec<u32>, SceneError> {
    let mut texture_cache: TextureCache = HashMap::new();
    let mut material_ids = Vec::with_capacity(materials.len());
    for m in materials {
        let (mtl_file, line) = origins
            .get(&m.name)
            .cloned()
            .unwrap_or_else(|| (path.to_path_buf(), 0));
        let source = Source {
            file: &mtl_file,
            line,
            policy,
        };
        let material = map_material(&source, m, builder, &mut texture_cache)?;
        material_ids.push(builder.add_material(material));
    }
    Ok(material_ids)
}

/// Adds tobj's models to the scene in order, each freed once copied. A
/// triangle is numbered in its object as if [`Chunked`] had made no cuts, so
/// that errors name it as the file has it.
fn add_models(
    path: &Path,
    models: Vec<tobj::Model>,
    splits: &[usize],
    material_ids: &[u32],
    builder: &mut SceneBuilder,
) -> Result<(), SceneError> {
    let mut default_id = None;
    // Triangles of the models so far, and of the ones before this one of
    // the same run of faces (those `Chunked` cut it into).
    let (mut triangles, mut first_triangle) = (0, 0);
    let mut splits = splits.iter().peekable();
    // Each model is freed once in the scene.
    for model in models {
        let count = model.mesh.indices.len() / 3;
        if count > 0 {
            if splits.next_if_eq(&&triangles).is_none() {
                first_triangle = 0;
            }
            triangles += count;
        }
        let material = model_material(path, &model, material_ids, &mut default_id, builder)?;
        add_model_triangles(path, &model, first_triangle, material, builder)?;
        first_triangle += count;
    }
    Ok(())
}

/// The scene material of a model's faces: its MTL material, or the default
/// material for faces without one (added to the scene at its first use,
/// then kept in `default_id`).
fn model_material(
    path: &Path,
    model: &tobj::Model,
    material_ids: &[u32],
    default_id: &mut Option<u32>,
    builder: &mut SceneBuilder,
) -> Result<u32, SceneError> {
    Ok(match model.mesh.material_id {
        Some(id) => *material_ids.get(id).ok_or_else(|| {
            SceneError::malformed(
                path,
                format!(
                    "object {} uses material {id}, which the MTL does not define",
                    quoted(&model.name)
                ),
            )
        })?,
        None => *default_id.get_or_insert_with(|| builder.add_material(default_material())),
    })
}

/// Adds the triangles of one model, with the file's vertices shared as they
/// are, its normals and texture coordinates where it has them.
/// `first_triangle` is the number of its first triangle in its object, for
/// error messages.
fn add_model_triangles(
    path: &Path,
    model: &tobj::Model,
    first_triangle: usize,
    material: u32,
    builder: &mut SceneBuilder,
) -> Result<(), SceneError> {
    let mesh = &model.mesh;
    let vertex = |i: u32| -> Option<Vec3> {
        let i = i as usize * 3;
        mesh.positions
            .get(i..i + 3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
    };
    let normal = |i: u32| -> Option<Vec3> {
        let i = i as usize * 3;
        mesh.normals
            .get(i..i + 3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
    };
    let uv = |i: u32| -> Option<Vec2> {
        let i = i as usize * 2;
        // OBJ's v runs upwards; textures store the top row first.
        mesh.texcoords
            .get(i..i + 2)
            .map(|t| Vec2::new(t[0], 1.0 - t[1]))
    };
    // tobj's `single_index`: one index per corner for every attribute,
    // so the file's vertices are shared as they are.
    builder.begin_shared_vertices(mesh.positions.len() / 3);
    for (f, face) in mesh.indices.chunks_exact(3).enumerate() {
        let f = first_triangle + f;
        let element = || format!("object {}, triangle {f}", quoted(&model.name));
        let get = |g: &dyn Fn(u32) -> Option<Vec3>| -> Option<[Vec3; 3]> {
            Some([g(face[0])?, g(face[1])?, g(face[2])?])
        };
        let positions = get(&vertex).ok_or_else(|| {
            SceneError::malformed(path, format!("{}: vertex index out of range", element()))
        })?;
        let normals = if mesh.normals.is_empty() {
            None
        } else {
            get(&normal)
        };
        let uvs = if mesh.texcoords.is_empty() {
            None
        } else {
            (|| Some([uv(face[0])?, uv(face[1])?, uv(face[2])?]))()
        };
        builder.add_indexed_triangle(
            path,
            &element,
            [face[0], face[1], face[2]],
            positions,
            normals,
            uvs,
            None,
            material,
        )?;
    }
    Ok(())
}

/// The OBJ file as tobj reads it, with a `g` line of the current object's
/// name inserted before a face whenever [`CHUNK_TRIANGLES`] triangles have
/// been read since the last `o`, `g` or `usemtl` line (or insertion).
/// tobj ends a model at a `g` line and exports its faces, so it never
/// holds more than about that many faces; the inserted line names the
/// object as it was named (tobj's rule: the line after its first
/// character, trimmed, or `unnamed_object`), so the models differ from
/// tobj's own only in where they are cut. `splits` records where, for
/// the triangle numbers of error messages.
struct Chunked<R> {
    inner: R,
    /// The line being handed out (after any inserted line), from `pos`.
    out: Vec<u8>,
    pos: usize,
    /// The next line of the file.
    line: Vec<u8>,
    /// The current object's name, as tobj names it.
    name: String,
    /// Triangles since the last `o`, `g`, `usemtl` or insertion.
    run: usize,
    /// Triangles read.
    triangles: usize,
    /// The number of triangles read before each insertion, increasing.
    splits: Vec<usize>,
    /// A read error (tobj reports only that reading failed).
    error: Option<std::io::Error>,
}

impl<R: BufRead> Chunked<R> {
    fn new(inner: R) -> Self {
        Self {
            inner,
            out: Vec::new(),
            pos: 0,
            line: Vec::new(),
            name: "unnamed_object".into(),
            run: 0,
            triangles: 0,
            splits: Vec::new(),
            error: None,
        }
    }

    /// Reads the next line into `out`, with a `g` line before it if it is
    /// a face that ends a chunk. An empty `out` is the end of the file.
    fn next_line(&mut self) -> std::io::Result<()> {
        self.out.clear();
        self.pos = 0;
        self.line.clear();
        self.inner.read_until(b'\n', &mut self.line)?;
        let text = String::from_utf8_lossy(&self.line);
        let text = text.trim_end_matches('\n').trim_end_matches('\r');
        let mut words = text.split_whitespace();
        match words.next() {
            Some("o" | "g") => {
                // tobj: the line after its first character, trimmed.
                let first = text.chars().next().map_or(0, char::len_utf8);
                let name = text[first..].trim();
                self.name = if name.is_empty() {
                    "unnamed_object".into()
                } else {
                    name.to_owned()
                };
                self.run = 0;
            }
            Some("usemtl") => self.run = 0,
            Some("f") => {
                if self.run >= CHUNK_TRIANGLES {
                    self.out.extend_from_slice(b"g ");
                    self.out.extend_from_slice(self.name.as_bytes());
                    self.out.push(b'\n');
                    self.splits.push(self.triangles);
                    self.run = 0;
                }
                let triangles = words.count().saturating_sub(2);
                self.run += triangles;
                self.triangles += triangles;
            }
            _ => {}
        }
        self.out.extend_from_slice(&self.line);
        Ok(())
    }
}

impl<R: BufRead> Read for Chunked<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let available = self.fill_buf()?;
        let n = available.len().min(buf.len());
        buf[..n].copy_from_slice(&available[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl<R: BufRead> BufRead for Chunked<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.pos == self.out.len()
            && let Err(e) = self.next_line()
        {
            // Kept for our error message; tobj sees a failed read.
            let kind = e.kind();
            self.error.get_or_insert(e);
            return Err(kind.into());
        }
        Ok(&self.out[self.pos..])
    }

    fn consume(&mut self, amount: usize) {
        self.pos = (self.pos + amount).min(self.out.len());
    }
}

/// Calls `f(n, line)` for each line of the file at `path` (`n` from 0),
/// as `str::lines` splits it, invalid UTF-8 replaced, streamed.
fn for_each_line(
    path: &Path,
    mut f: impl FnMut(usize, &str) -> Result<(), SceneError>,
) -> Result<(), SceneError> {
    let file = File::open(path).map_err(|e| SceneError::io(path, e))?;
    let mut reader = BufReader::with_capacity(READ_BUFFER, file);
    let mut line = Vec::new();
    for n in 0.. {
        line.clear();
        reader
            .read_until(b'\n', &mut line)
            .map_err(|e| SceneError::io(path, e))?;
        if line.is_empty() {
            break;
        }
        if line.ends_with(b"\n") {
            line.pop();
            if line.ends_with(b"\r") {
                line.pop();
            }
        }
        f(n, &String::from_utf8_lossy(&line))?;
    }
    Ok(())
}

/// What tobj reads from one MTL file.
type MtlMaterials = <tobj::MTLLoadResult as IntoIterator>::Item;

/// One MTL file as read: where it is, tobj's materials, the line of each `newmtl`.
struct LoadedMtl {
    file: PathBuf,
    materials: MtlMaterials,
    lines: Vec<(String, usize)>,
}

/// One `mtllib`: resolved through `policy` (inside the scene's folder, a
/// file and not a folder), its values checked line by line ([`check_mtl`]),
/// then parsed by tobj. Returns the file, tobj's result and the line of each
/// `newmtl`.
fn load_mtl(
    obj: &Path,
    reference: &Path,
    policy: &crate::paths::ReferencePolicy,
) -> Result<LoadedMtl, SceneError> {
    let written = reference.to_string_lossy();
    let file = policy.resolve(obj, "mtllib", &written)?;
    let text = std::fs::read(&file).map_err(|e| SceneError::io(&file, e))?;
    let lines = check_mtl(&file, &text)?;
    let materials = tobj::load_mtl_buf(&mut text.as_slice())
        .map_err(|e| SceneError::malformed(&file, describe(&e)))?;
    Ok(LoadedMtl {
        file,
        materials,
        lines,
    })
}

/// The value checks of an MTL file, before tobj reads it (tobj reads `nan`
/// as a number and panics on a colour with fewer than three numbers). Returns
/// the line of each `newmtl`.
fn check_mtl(path: &Path, text: &[u8]) -> Result<Vec<(String, usize)>, SceneError> {
    let text = String::from_utf8_lossy(text);
    let mut material = String::new();
    let mut newmtl = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let element = || {
            if material.is_empty() {
                format!("line {}", n + 1)
            } else {
                format!("material {}, line {}", quoted(&material), n + 1)
            }
        };
        let invalid = |message: String| SceneError::invalid(path, element(), message);
        let number = |word: Option<&str>| -> Result<f32, SceneError> {
            let word = word.ok_or_else(|| invalid(format!("{key} needs a number")))?;
            match word.parse::<f32>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(invalid(format!(
                    "{key} {} is not a finite number",
                    quoted(word)
                ))),
            }
        };
        let in_range = |x: f32, low: f32, high: f32| -> Result<f32, SceneError> {
            if (low..=high).contains(&x) {
                Ok(x)
            } else {
                Err(invalid(format!(
                    "{key} must be in [{low}, {high}], got {x}"
                )))
            }
        };
        match key {
            "newmtl" => {
                material = line["newmtl".len()..].trim().to_owned();
                newmtl.push((material.clone(), n + 1));
            }
            "Ka" | "Kd" | "Ks" | "Ke" | "Tf" => {
                for _ in 0..3 {
                    in_range(number(words.next())?, 0.0, f32::MAX)?;
                }
            }
            "Ns" => {
                in_range(number(words.next())?, 0.0, f32::MAX)?;
            }
            // Ni <= 0 is refused where the material is a dielectric (real files
            // write `Ni 0` on opaque materials).
            "Ni" => {
                number(words.next())?;
            }
            "d" | "Tr" | "Pm" => {
                in_range(number(words.next())?, 0.0, 1.0)?;
            }
            "Pr" => {
                in_range(number(words.next())?, 0.0, f32::MAX)?;
            }
            "illum" => {
                let word = words.next().unwrap_or("");
                if word.parse::<u8>().is_err() {
                    return Err(invalid(format!(
                        "illum {} is not a whole number in 0..=255",
                        quoted(word)
                    )));
                }
            }
            _ => {}
        }
    }
    Ok(newmtl)
}

/// What [`check_lines`] found besides errors.
struct ChecksPassed {
    /// The first `usemtl` line (from 1) of each material name.
    usemtl: Vec<(usize, String)>,
    /// `v` lines.
    vertices: usize,
    /// Triangles of the faces (a face of `k` vertices is a fan of `k - 2`).
    triangles: usize,
}

/// Finds the first `v`, `vn` or `vt` line with a number that does not parse or is
/// not finite, the first face with fewer than three vertices, and the first
/// face (or line, or point) index that is not a whole number or refers to no
/// element, so that the error names the line (tobj's errors do not; it drops
/// short faces silently, and overflows on an index such as -9223372036854775808).
/// Negative indices count back from the elements read so far; positive ones
/// may refer to any element of the file. Two passes over the file.
fn check_lines(path: &Path) -> Result<ChecksPassed, SceneError> {
    let mut totals = [0usize; 3];
    let mut triangles = 0;
    let mut usemtl: Vec<(usize, String)> = Vec::new();
    let mut named = std::collections::HashSet::new();
    for_each_line(path, |n, line| {
        let line = line.trim();
        match line.split_whitespace().next() {
            Some("v") => totals[0] += 1,
            Some("vt") => totals[1] += 1,
            Some("vn") => totals[2] += 1,
            Some("f") => triangles += line.split_whitespace().count().saturating_sub(3),
            Some("usemtl") => {
                let name = line["usemtl".len()..].trim();
                if !name.is_empty() && named.insert(name.to_owned()) {
                    usemtl.push((n + 1, name.to_owned()));
                }
            }
            _ => {}
        }
        Ok(())
    })?;
    let mut counts = [0usize; 3];
    for_each_line(path, |n, line| {
        let element = || format!("line {}", n + 1);
        let mut words = line.split_whitespace();
        match words.next() {
            Some(kind @ ("v" | "vn" | "vt")) => {
                counts[match kind {
                    "v" => 0,
                    "vt" => 1,
                    _ => 2,
                }] += 1;
                for word in words {
                    match word.parse::<f32>() {
                        Ok(x) if x.is_finite() => {}
                        _ => {
                            return Err(SceneError::invalid(
                                path,
                                element(),
                                format!("{} is not a finite number", quoted(word)),
                            ));
                        }
                    }
                }
            }
            Some(kind @ ("f" | "l" | "p")) => {
                if kind == "f" && words.clone().count() < 3 {
                    return Err(SceneError::invalid(
                        path,
                        element(),
                        "a face needs at least three vertices",
                    ));
                }
                for word in words {
                    check_face_vertex(word, &counts, &totals)
                        .map_err(|message| SceneError::invalid(path, element(), message))?;
                }
            }
            _ => {}
        }
        Ok(())
    })?;
    Ok(ChecksPassed {
        usemtl,
        vertices: totals[0],
        triangles,
    })
}

/// One `v/vt/vn` of a face: whole numbers, not 0, referring to existing elements.
fn check_face_vertex(word: &str, counts: &[usize; 3], totals: &[usize; 3]) -> Result<(), String> {
    const NAMES: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let parts: Vec<&str> = word.split('/').collect();
    if parts.len() > 3 {
        return Err(format!(
            "face vertex {} has more than three indices (v/vt/vn)",
            quoted(word)
        ));
    }
    for (k, part) in parts.iter().enumerate() {
        if part.is_empty() && k > 0 {
            continue;
        }
        let name = NAMES[k];
        let Ok(index) = part.parse::<i64>() else {
            return Err(format!(
                "face {name} index {} is not a whole number",
                quoted(part)
            ));
        };
        let valid = if index > 0 {
            index as u64 <= totals[k] as u64
        } else {
            index != 0 && index.unsigned_abs() <= counts[k] as u64
        };
        if !valid {
            let available = if index > 0 { totals[k] } else { counts[k] };
            return Err(format!(
                "face {name} index {index} refers to no {name} ({available} defined{})",
                if index < 0 { " so far" } else { "" }
            ));
        }
    }
    Ok(())
}

fn describe(e: &tobj::LoadError) -> String {
    use tobj::LoadError::*;
    match e {
        OpenFileFailed => "the file (or a material library it names) cannot be opened".into(),
        ReadError => "read error".into(),
        UnrecognizedCharacter => "unrecognized character".into(),
        PositionParseError => "malformed vertex position (v)".into(),
        NormalParseError => "malformed vertex normal (vn)".into(),
        TexcoordParseError => "malformed texture coordinate (vt)".into(),
        FaceParseError => "malformed face (f)".into(),
        MaterialParseError => "malformed material library".into(),
        InvalidObjectName => "invalid object name".into(),
        InvalidPolygon => "face with fewer than three vertices".into(),
        FaceVertexOutOfBounds => "a face refers to a vertex that does not exist".into(),
        FaceTexCoordOutOfBounds => {
            "a face refers to a texture coordinate that does not exist".into()
        }
        FaceNormalOutOfBounds => "a face refers to a normal that does not exist".into(),
        FaceColorOutOfBounds => "a face refers to a vertex colour that does not exist".into(),
        other => format!("{other:?}"),
    }
}

fn param(m: &tobj::Material, key: &str) -> Option<f32> {
    m.unknown_param
        .get(key)
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
}

fn rgb(c: Option<[f32; 3]>) -> Vec3 {
    c.map_or(Vec3::ZERO, Vec3::from_array)
}

/// Where a material was defined: its MTL file (whose folder its textures
/// are relative to) and the line of its `newmtl` (0: unknown).
struct Source<'a> {
    file: &'a Path,
    line: usize,
    policy: &'a crate::paths::ReferencePolicy,
}

/// The mapping of the `material` module docs, with range checks.
fn map_material(
    source: &Source,
    m: &tobj::Material,
    builder: &mut SceneBuilder,
    textures: &mut TextureCache,
) -> Result<Material, SceneError> {
    let path = source.file;
    let element = || {
        if source.line > 0 {
            format!("material {} (line {})", quoted(&m.name), source.line)
        } else {
            format!("material {}", quoted(&m.name))
        }
    };
    let kd = rgb(m.diffuse);
    let ks = rgb(m.specular);
    let ke = rgb(m.emissive);
    for (name, c) in [("Kd", kd), ("Ks", ks), ("Ke", ke)] {
        if !c.is_finite() || c.min_element() < 0.0 {
            return Err(SceneError::invalid(
                path,
                element(),
                format!("{name} must be finite and non-negative, got {c}"),
            ));
        }
    }
    for (name, c) in [("Kd", kd), ("Ks", ks)] {
        if c.max_element() > 1.0 {
            builder.report.warnings.push(format!(
                "{}: {}: {name} {c} is above 1 and is clamped to 1",
                path.display(),
                element()
            ));
        }
    }
    let roughness = param(m, "Pr");
    let metallic = param(m, "Pm");
    if let Some(r) = roughness.filter(|r| !(r.is_finite() && *r >= 0.0)) {
        return Err(SceneError::invalid(
            path,
            element(),
            format!("roughness Pr must be >= 0, got {r}"),
        ));
    }
    let ior = m.optical_density.unwrap_or(1.5);
    let dissolve = m
        .dissolve
        .or_else(|| param(m, "Tr").map(|tr| 1.0 - tr))
        .unwrap_or(1.0);
    let illum = m.illumination_model.unwrap_or(2);
    let smooth_or_pr = roughness.map_or(0.0, |r| r * r);
    let surface = if illum == 7 || dissolve < OPAQUE_DISSOLVE {
        if !(ior > 0.0 && ior.is_finite()) {
            return Err(SceneError::invalid(
                path,
                element(),
                format!("index of refraction Ni must be > 0, got {ior}"),
            ));
        }
        Surface::Dielectric {
            model: MicrofacetModel::new(NdfKind::Ggx, smooth_or_pr, Shadowing::Smith),
            ior,
            tint: Vec3::ONE,
        }
    } else if illum == 5 {
        Surface::Conductor {
            model: MicrofacetModel::new(NdfKind::Ggx, smooth_or_pr, Shadowing::Smith),
            fresnel: Fresnel::Schlick {
                f0: ks.min(Vec3::ONE),
            },
        }
    } else if metallic.is_some_and(|pm| pm >= 0.5) {
        let r = roughness.unwrap_or(0.5);
        Surface::Conductor {
            model: MicrofacetModel::new(NdfKind::Ggx, r * r, Shadowing::Smith),
            fresnel: Fresnel::Schlick {
                f0: kd.min(Vec3::ONE),
            },
        }
    } else if ks.max_element() > 0.0 {
        let ns = m.shininess.unwrap_or(0.0).max(0.0);
        metal_rough_surface(
            MetalRough {
                // supp. eq. 5: n = 2/alpha^2 - 2, i.e. roughness^2 = alpha.
                roughness: (2.0 / (ns + 2.0)).sqrt().sqrt(),
                specular_color: ks.min(Vec3::ONE) / MTL_COAT_F0,
                ior: MTL_COAT_IOR,
                ..MetalRough::new(kd.min(Vec3::ONE), 0.0, 1.0)
            },
            NdfKind::BlinnPhong,
            Shadowing::Smith,
        )
    } else {
        Surface::Diffuse {
            reflectance: kd.min(Vec3::ONE),
        }
    };
    let surface = textured(source, m, surface, builder, textures)?;
    Ok(Material {
        name: m.name.clone(),
        surface,
        emission: ke,
        medium: None,
        maps: Maps {
            normal: normal_map(source, m, &element(), builder, textures)?,
            ..Maps::default()
        },
    })
}

/// The material's `norm` (tangent-space normal map) or, without one, its
/// `bump`/`map_Bump` (height map; `-bm` scales it, 1 by default). Other
/// options of the statement are skipped with a warning.
fn normal_map(
    source: &Source,
    m: &tobj::Material,
    element: &str,
    builder: &mut SceneBuilder,
    textures: &mut HashMap<(PathBuf, bool), usize>,
) -> Result<Option<NormalMap>, SceneError> {
    let (key, statement) = match (m.unknown_param.get("norm"), &m.normal_texture) {
        (Some(norm), _) => ("norm", norm),
        (None, Some(bump)) => ("bump", bump),
        (None, None) => return Ok(None),
    };
    let (file, scale, ignored) = texture_options(statement);
    let scale = match scale {
        Some(s) => s
            .parse::<f32>()
            .ok()
            .filter(|s| s.is_finite())
            .ok_or_else(|| {
                SceneError::invalid(
                    source.file,
                    element,
                    format!("{key}: -bm needs a finite number, got {}", quoted(s)),
                )
            })?,
        None => 1.0,
    };
    if !ignored.is_empty() {
        builder.report.warnings.push(format!(
            "{}: {element}: {key}: options {} ignored",
            source.file.display(),
            quoted(&ignored.join(" "))
        ));
    }
    let texture = load_texture(source, element, key, file, false, builder, textures)?;
    let kind = if key == "norm" {
        NormalMapKind::Tangent { scale }
    } else {
        NormalMapKind::Height { scale }
    };
    Ok(Some(NormalMap { texture, kind }))
}

/// A texture statement's file (the text after its options), its `-bm`
/// value, and the other options (MTL options start with `-`; all but
/// `-bm`, `-clamp`, `-imfchan` and the three-number `-o`/`-s`/`-t` are taken
/// to have one value). Without options the whole text is the file name.
fn texture_options(statement: &str) -> (&str, Option<&str>, Vec<&str>) {
    let text = statement.trim();
    if !text.starts_with('-') {
        return (text, None, Vec::new());
    }
    let words: Vec<&str> = text.split_whitespace().collect();
    let (mut i, mut bm, mut ignored) = (0, None, Vec::new());
    while i + 1 < words.len() && words[i].starts_with('-') {
        let values = match words[i] {
            "-o" | "-s" | "-t" => 3,
            _ => 1,
        };
        let end = (i + 1 + values).min(words.len() - 1);
        if words[i] == "-bm" {
            bm = Some(words[i + 1]);
        } else {
            ignored.extend_from_slice(&words[i..end]);
        }
        i = end;
    }
    // The file name is the rest (it may contain spaces).
    let rest = words[i..].join(" ");
    let file = text.rfind(&rest).map_or(text, |at| &text[at..]);
    (file, bm, ignored)
}

/// The textures of the `material` module docs: `map_Kd` on a diffuse or
/// coated surface, `map_Ks` and `map_Ns` on a coated one; a warning names
/// every map that does not apply.
fn textured(
    source: &Source,
    m: &tobj::Material,
    surface: Surface,
    builder: &mut SceneBuilder,
    textures: &mut TextureCache,
) -> Result<Surface, SceneError> {
    let element = if source.line > 0 {
        format!("material {} (line {})", quoted(&m.name), source.line)
    } else {
        format!("material {}", quoted(&m.name))
    };
    let coat = match surface {
        Surface::Coated(c) if c.metallic == 0.0 => Some(c),
        _ => None,
    };
    let takes_kd = coat.is_some() || matches!(surface, Surface::Diffuse { .. });
    let mut ignored = Vec::new();
    let mut load = |key: &str, file: &Option<String>, applies: bool, srgb: bool| match file {
        Some(file) if applies => {
            load_texture(source, &element, key, file, srgb, builder, textures).map(Some)
        }
        Some(file) => {
            ignored.push(format!("{key} {}", quoted(file)));
            Ok(None)
        }
        None => Ok(None),
    };
    let kd_map = load("map_Kd", &m.diffuse_texture, takes_kd, true)?;
    let ks_map = load("map_Ks", &m.specular_texture, coat.is_some(), true)?;
    let ns_map = load("map_Ns", &m.shininess_texture, coat.is_some(), false)?;
    for what in ignored {
        builder.report.warnings.push(format!(
            "{}: {element}: {what} ignored: it applies to diffuse (map_Kd) or Kd + Ks materials only",
            source.file.display()
        ));
    }
    if kd_map.is_none() && ks_map.is_none() && ns_map.is_none() {
        return Ok(surface);
    }
    Ok(match (coat, surface) {
        (Some(c), _) => Surface::Textured(TexturedPbr {
            base_color: c.base_color,
            base_color_texture: kd_map,
            metallic: 0.0,
            roughness: c.model.alpha().sqrt(),
            metallic_roughness_texture: None,
            transmission: 0.0,
            transmission_texture: None,
            specular: c.specular,
            specular_color: c.specular_color,
            ior: c.ior,
            specular_color_texture: ks_map,
            shininess_texture: ns_map.map(|t| (m.shininess.unwrap_or(0.0).max(0.0), t)),
            ndf: c.model.ndf.kind(),
            shadowing: c.model.shadowing,
        }),
        (None, Surface::Diffuse { reflectance }) => {
            Surface::Textured(TexturedPbr::lambertian(reflectance, kd_map))
        }
        (None, other) => other,
    })
}

/// Loads the texture of MTL key `key` (`map_Kd`, ...) through the cache.
#[allow(clippy::too_many_arguments)]
fn load_texture(
    source: &Source,
    element: &str,
    key: &str,
    file: &str,
    srgb: bool,
    builder: &mut SceneBuilder,
    cache: &mut TextureCache,
) -> Result<usize, SceneError> {
    let path = source.file;
    let texture_path = source
        .policy
        .resolve(path, &format!("{element}: {key}"), file.trim())?;
    let texture_path = (texture_path, srgb);
    if let Some(&id) = cache.get(&texture_path) {
        return Ok(id);
    }
    let image = image::open(&texture_path.0)
        .map_err(|e| {
            SceneError::invalid(
                path,
                format!("{element}: {key} {}", quoted(file)),
                e.to_string(),
            )
        })?
        .to_rgba8();
    let texture = Texture::from_u8(image.width(), image.height(), 4, image.as_raw(), srgb)
        .ok_or_else(|| {
            SceneError::invalid(
                path,
                format!("{element}: {key} {}", quoted(file)),
                "the image is empty",
            )
        })?;
    let id = builder.add_texture(texture);
    cache.insert(texture_path, id);
    Ok(id)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder for one test's files.
    fn folder(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("obj-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A strip of `quads` quads in one object named "strip", as an OBJ
    /// text: vertex `2k + 1` is `(k, 0, 0)`, `2k + 2` is `(k, 1, 0)`;
    /// vertex `bad` if given is `v 1e30 0 0 1e-38` (its w makes x
    /// overflow). Quad `k` is triangles `2k` (corners `2k + 1`, `2k + 3`,
    /// `2k + 2`) and `2k + 1`.
    fn strip(quads: usize, bad: Option<usize>) -> String {
        let mut text = String::from("o strip\n");
        for k in 0..=quads {
            for y in [0, 1] {
                if bad == Some(2 * k + y + 1) {
                    text += "v 1e30 0 0 1e-38\n";
                } else {
                    text += &format!("v {k} {y} 0\n");
                }
            }
        }
        for k in 0..quads {
            let (a, b) = (2 * k + 1, 2 * k + 2);
            text += &format!("f {a} {} {b}\nf {b} {} {}\n", a + 2, a + 2, b + 2);
        }
        text
    }

    /// A mesh longer than a chunk: every triangle, in order, with the
    /// file's corners; vertices shared within each chunk; the chunk cut
    /// made where promised.
    #[test]
    fn chunked_load_keeps_every_triangle() {
        let quads = CHUNK_TRIANGLES / 2 + 1000;
        let path = folder("chunked").join("strip.obj");
        std::fs::write(&path, strip(quads, None)).unwrap();
        let policy = crate::paths::ReferencePolicy::new(&path, false);
        let builder = load(&path, &policy).unwrap();
        assert_eq!(builder.triangles.len(), 2 * quads);
        for (t, tri) in builder.triangles.iter().enumerate() {
            let k = (t / 2) as f32;
            let want = if t % 2 == 0 {
                [(k, 0.0), (k + 1.0, 0.0), (k, 1.0)]
            } else {
                [(k, 1.0), (k + 1.0, 0.0), (k + 1.0, 1.0)]
            };
            let got = tri.map(|v| builder.positions[v as usize]);
            assert_eq!(got, want.map(|(x, y)| Vec3::new(x, y, 0.0)), "triangle {t}");
        }
        // One cut, between two quads: its column of two vertices is
        // stored twice.
        assert_eq!(builder.positions.len(), 2 * (quads + 1) + 2);
        let file = BufReader::new(File::open(&path).unwrap());
        let mut reader = Chunked::new(file);
        std::io::copy(&mut reader, &mut std::io::sink()).unwrap();
        assert_eq!(reader.splits, [CHUNK_TRIANGLES]);
    }

    /// An error in a triangle past a cut names the triangle by its number
    /// in the object, as without cuts.
    #[test]
    fn errors_past_a_cut_number_triangles_in_the_object() {
        let quads = CHUNK_TRIANGLES / 2 + 10;
        // Vertex 2m + 1 is first used by triangle 2(m - 1).
        let m = quads - 3;
        let path = folder("numbering").join("strip.obj");
        std::fs::write(&path, strip(quads, Some(2 * m + 1))).unwrap();
        let policy = crate::paths::ReferencePolicy::new(&path, false);
        let error = load(&path, &policy).expect_err("an error").to_string();
        let first_use = 2 * (m - 1);
        assert!(first_use > CHUNK_TRIANGLES);
        assert!(
            error.contains(&format!("object \"strip\", triangle {first_use}")),
            "{error}"
        );
    }
}
