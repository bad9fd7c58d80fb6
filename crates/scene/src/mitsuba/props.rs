//! Typed reads of one plugin's properties and children, as Mitsuba's
//! `Properties` does (note §1.2: an integer may be read as a float, not the
//! reverse; a vector may stand for a colour), remembering what was read so
//! that what a plugin never reads can be named in one warning.

use std::cell::RefCell;
use std::collections::HashMap;

use glam::{DMat4, DVec3, Vec3};

use super::xml::{Child, Location, Object, Value, element_name};
use crate::error::{SceneError, quoted};

/// `xyz_to_srgb(1, 1, 1)`: the RGB of a uniform spectrum of value 1 on an
/// emitter in Mitsuba's RGB variants (`get_emissive_texture`,
/// `src/core/properties.cpp`; note §1.7, measured: value 2 gives
/// (2.40959, 1.89658, 1.81783)). Reflectances take a uniform spectrum as is.
pub const EMISSIVE_WHITE: Vec3 = Vec3::new(1.204794, 0.948291, 0.908916);

/// Deepest chain of references followed (`twosided` of a ref of a ref...):
/// a cycle ends here with an error instead of a stack overflow.
pub const MAX_REFERENCE_DEPTH: usize = 16;

/// A colour property: a constant or a texture object.
#[derive(Clone, Copy, Debug)]
pub enum Color<'a> {
    /// A constant RGB.
    Rgb(Vec3),
    /// A `<texture>` (bitmap, checkerboard, ...).
    Texture(&'a Object),
}

/// One plugin instance being read.
pub struct Plugin<'a> {
    /// The object.
    pub object: &'a Object,
    ids: &'a HashMap<String, &'a Object>,
    used: RefCell<Vec<bool>>,
    used_children: RefCell<Vec<bool>>,
}

impl<'a> Plugin<'a> {
    /// Reads `object`, resolving references through `ids`.
    pub fn new(object: &'a Object, ids: &'a HashMap<String, &'a Object>) -> Self {
        Self {
            object,
            ids,
            used: RefCell::new(vec![false; object.properties.len()]),
            used_children: RefCell::new(vec![false; object.children.len()]),
        }
    }

    /// The plugin name (`type`).
    pub fn plugin(&self) -> &'a str {
        &self.object.plugin
    }

    /// `line 12: <bsdf type="diffuse">`.
    pub fn element(&self) -> String {
        element_name(&self.object.at, &self.object.tag, &self.object.plugin)
    }

    /// An error naming this plugin's file and element.
    pub fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError::invalid(self.object.at.file.as_path(), self.element(), message)
    }

    /// An error for property `name`, naming the line it was written on.
    fn property_error(&self, at: &Location, name: &str, message: impl Into<String>) -> SceneError {
        SceneError::invalid(
            at.file.as_path(),
            format!(
                "line {}: <{} type={}> property {}",
                at.line,
                self.object.tag,
                quoted(&self.object.plugin),
                quoted(name)
            ),
            message,
        )
    }

    /// The value of property `name` (the last one written, as Mitsuba keeps),
    /// marked as read.
    fn value(&self, name: &str) -> Option<(&'a Value, &'a Location)> {
        let props = &self.object.properties;
        let i = props.iter().rposition(|p| p.name == name)?;
        let mut used = self.used.borrow_mut();
        for (j, p) in props.iter().enumerate() {
            if p.name == name {
                used[j] = true;
            }
        }
        Some((&props[i].value, &props[i].at))
    }

    /// Whether property `name` is given (without reading it).
    pub fn has(&self, name: &str) -> bool {
        self.object.properties.iter().any(|p| p.name == name)
            || self.children_named(name).next().is_some()
    }

    fn wrong_kind(&self, name: &str, at: &Location, expected: &str, got: &Value) -> SceneError {
        self.property_error(
            at,
            name,
            format!("expected {expected}, got <{}>", got.kind()),
        )
    }

    /// A float (an integer is accepted).
    pub fn float(&self, name: &str) -> Result<Option<f64>, SceneError> {
        match self.value(name) {
            None => Ok(None),
            Some((Value::Float(v), _)) => Ok(Some(*v)),
            Some((Value::Integer(v), _)) => Ok(Some(*v as f64)),
            Some((v, at)) => Err(self.wrong_kind(name, at, "a <float>", v)),
        }
    }

    /// A float, or `default`.
    pub fn float_or(&self, name: &str, default: f64) -> Result<f64, SceneError> {
        Ok(self.float(name)?.unwrap_or(default))
    }

    /// An integer (a float is an error, as in Mitsuba).
    pub fn integer(&self, name: &str) -> Result<Option<i64>, SceneError> {
        match self.value(name) {
            None => Ok(None),
            Some((Value::Integer(v), _)) => Ok(Some(*v)),
            Some((v, at)) => Err(self.wrong_kind(name, at, "an <integer>", v)),
        }
    }

    /// A boolean, or `default`.
    pub fn boolean_or(&self, name: &str, default: bool) -> Result<bool, SceneError> {
        match self.value(name) {
            None => Ok(default),
            Some((Value::Boolean(v), _)) => Ok(*v),
            Some((v, at)) => Err(self.wrong_kind(name, at, "a <boolean>", v)),
        }
    }

    /// A string.
    pub fn string(&self, name: &str) -> Result<Option<&'a str>, SceneError> {
        match self.value(name) {
            None => Ok(None),
            Some((Value::String(v), _)) => Ok(Some(v)),
            Some((v, at)) => Err(self.wrong_kind(name, at, "a <string>", v)),
        }
    }

    /// A point or vector.
    pub fn vector(&self, name: &str) -> Result<Option<DVec3>, SceneError> {
        match self.value(name) {
            None => Ok(None),
            Some((Value::Vector(v), _)) => Ok(Some(*v)),
            Some((v, at)) => Err(self.wrong_kind(name, at, "a <point> or <vector>", v)),
        }
    }

    /// A transform, or the identity.
    pub fn transform(&self, name: &str) -> Result<DMat4, SceneError> {
        match self.value(name) {
            None => Ok(DMat4::IDENTITY),
            Some((Value::Transform(m), _)) => Ok(*m),
            Some((v, at)) => Err(self.wrong_kind(name, at, "a <transform>", v)),
        }
    }

    /// An index of refraction: a number, or a name of Mitsuba's table
    /// (`include/mitsuba/render/ior.h`; note §2.2: a numeric string or an
    /// integer is an error there too).
    pub fn ior(&self, name: &str, default: &str) -> Result<f32, SceneError> {
        match self.value(name) {
            Some((Value::Float(v), at)) => {
                if *v > 0.0 {
                    Ok(*v as f32)
                } else {
                    Err(self.property_error(at, name, format!("must be > 0, got {v}")))
                }
            }
            Some((Value::String(s), at)) => super::tables::dielectric(s).ok_or_else(|| {
                let names: Vec<&str> = super::tables::DIELECTRICS.iter().map(|d| d.0).collect();
                self.property_error(
                    at,
                    name,
                    format!("unknown IOR {} (known: {})", quoted(s), names.join(", ")),
                )
            }),
            Some((v, at)) => Err(self.wrong_kind(name, at, "a <float> or a <string> name", v)),
            None => Ok(super::tables::dielectric(default).expect("defaults are table names")),
        }
    }

    /// A colour: float, rgb, spectrum (uniform), vector, or a texture child
    /// of that name. Emitter values (`emitter`) take a uniform spectrum as
    /// [`EMISSIVE_WHITE`] times its value; reflectances (`bounded`) must lie
    /// in [0, 1] (an error in Mitsuba too).
    pub fn color(
        &self,
        name: &str,
        emitter: bool,
        bounded: bool,
    ) -> Result<Option<Color<'a>>, SceneError> {
        if let Some(texture) = self.child_named(name)? {
            return Ok(Some(Color::Texture(texture)));
        }
        let Some((value, at)) = self.value(name) else {
            return Ok(None);
        };
        let rgb = match value {
            Value::Float(v) => DVec3::splat(*v),
            Value::Integer(v) => DVec3::splat(*v as f64),
            Value::Rgb(v) | Value::Vector(v) => *v,
            Value::Spectrum(v) if emitter => *v * EMISSIVE_WHITE.as_dvec3(),
            Value::Spectrum(v) => DVec3::splat(*v),
            v => return Err(self.wrong_kind(name, at, "an <rgb>, <spectrum> or <float>", v)),
        };
        if !rgb.is_finite() || rgb.min_element() < 0.0 {
            return Err(self.property_error(
                at,
                name,
                format!("must be finite and >= 0, got {rgb}"),
            ));
        }
        if bounded && rgb.max_element() > 1.0 {
            return Err(self.property_error(
                at,
                name,
                format!("a reflectance must lie in [0, 1], got {rgb}"),
            ));
        }
        Ok(Some(Color::Rgb(rgb.as_vec3())))
    }

    /// A constant [`Plugin::color`]: a texture there is an error naming it.
    pub fn rgb(
        &self,
        name: &str,
        emitter: bool,
        bounded: bool,
    ) -> Result<Option<Vec3>, SceneError> {
        match self.color(name, emitter, bounded)? {
            None => Ok(None),
            Some(Color::Rgb(c)) => Ok(Some(c)),
            Some(Color::Texture(_)) => {
                Err(self.error(format!("a textured {name} is not supported")))
            }
        }
    }

    /// The nested objects (or objects referred to) with tag `tag`, in order,
    /// marked as read.
    pub fn children(&self, tag: &str) -> Result<Vec<&'a Object>, SceneError> {
        let mut out = Vec::new();
        for (i, child) in self.object.children.iter().enumerate() {
            let object = self.resolve(child)?;
            if object.tag == tag {
                self.used_children.borrow_mut()[i] = true;
                out.push(object);
            }
        }
        Ok(out)
    }

    /// The one child of tag `tag`, if any; two are an error.
    pub fn child(&self, tag: &str) -> Result<Option<&'a Object>, SceneError> {
        let children = self.children(tag)?;
        match children.as_slice() {
            [] => Ok(None),
            [one] => Ok(Some(one)),
            [_, second, ..] => Err(SceneError::invalid(
                second.at.file.as_path(),
                element_name(&second.at, &second.tag, &second.plugin),
                format!("{} takes one <{tag}>, this is a second", self.element()),
            )),
        }
    }

    fn children_named<'s>(
        &'s self,
        name: &'s str,
    ) -> impl Iterator<Item = (usize, &'a Child)> + 's {
        self.object
            .children
            .iter()
            .enumerate()
            .filter(move |(_, c)| match c {
                Child::Object(o) => o.name.as_deref() == Some(name),
                Child::Ref { name: n, .. } => n.as_deref() == Some(name),
            })
    }

    /// The child object given as property `name` (a texture), if any.
    fn child_named(&self, name: &str) -> Result<Option<&'a Object>, SceneError> {
        let Some((i, child)) = self.children_named(name).last() else {
            return Ok(None);
        };
        self.used_children.borrow_mut()[i] = true;
        self.resolve(child).map(Some)
    }

    /// The object a child stands for (a reference resolved).
    pub fn resolve(&self, child: &'a Child) -> Result<&'a Object, SceneError> {
        match child {
            Child::Object(o) => Ok(o),
            Child::Ref { id, at, .. } => self.ids.get(id).copied().ok_or_else(|| {
                SceneError::invalid(
                    at.file.as_path(),
                    format!("line {}: <ref>", at.line),
                    format!("no object has id {}", quoted(id)),
                )
            }),
        }
    }

    /// One warning naming what this plugin did not read: the properties and
    /// children it ignores (Mitsuba refuses them; a renderer with fewer
    /// features says what it skipped).
    pub fn unused(&self) -> Option<String> {
        let used = self.used.borrow();
        let mut names: Vec<String> = self
            .object
            .properties
            .iter()
            .zip(used.iter())
            .filter(|(_, u)| !**u)
            .map(|(p, _)| quoted(&p.name))
            .collect();
        let used_children = self.used_children.borrow();
        for (child, used) in self.object.children.iter().zip(used_children.iter()) {
            if !used {
                let what = match child {
                    Child::Object(o) => format!("<{} type={}>", o.tag, quoted(&o.plugin)),
                    Child::Ref { id, .. } => format!("<ref id={}>", quoted(id)),
                };
                names.push(what);
            }
        }
        (!names.is_empty()).then(|| {
            format!(
                "{}: {}: ignored (not supported here): {}",
                self.object.at.file.display(),
                self.element(),
                names.join(", ")
            )
        })
    }
}
