//! Mitsuba 3 XML documents as a tree of objects and their properties, after
//! the format's own rules (mitsuba3 v3.9.1, `src/core/parser.cpp`; measured
//! in `shared/notes/mitsuba-format.md` §1): `$name` substitution in every
//! attribute, `<default>`, `<include>` spliced in, `<path>`, the upgrade of
//! files older than 2.0.0 (camelCase property names), typed property values
//! and transforms. References (`<ref>`) stay references here; the scene
//! builder resolves them once the whole document is read.

use std::path::{Path, PathBuf};
use std::rc::Rc;

use glam::{DMat4, DVec3};

use super::numbers::{parse_f64, triple};
use super::transform;
use crate::error::{SceneError, quoted};
use crate::paths::ReferencePolicy;

/// Deepest element nesting accepted: the classic scenes nest 5 deep; the
/// object tree is walked recursively, so hostile depth must stop early.
pub const MAX_DEPTH: usize = 64;

/// Deepest chain of `<include>` (Mitsuba's own limit, parser.cpp).
pub const MAX_INCLUDE_DEPTH: usize = 15;

/// Largest scene file read, in bytes: an XML scene is a page of text; its
/// meshes live in other files.
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// Most XML nodes in one file (roxmltree's limit; a 64 MB file of empty
/// elements would otherwise make some 10^7 nodes of ~100 bytes each).
const MAX_NODES: u32 = 1 << 20;

/// Object tags (every one but the root `<scene>` needs `type`).
const OBJECT_TAGS: &[&str] = &[
    "scene",
    "shape",
    "bsdf",
    "emitter",
    "sensor",
    "film",
    "rfilter",
    "sampler",
    "integrator",
    "texture",
    "medium",
    "phase",
    "volume",
];

/// Where an element was written.
#[derive(Clone, Debug)]
pub struct Location {
    /// The file.
    pub file: Rc<PathBuf>,
    /// 1-based line.
    pub line: u32,
}

/// A plugin instance: `<shape type="obj" id="..." name="...">` and what it holds.
#[derive(Clone, Debug)]
pub struct Object {
    /// Element name (`shape`, `bsdf`, ...).
    pub tag: String,
    /// Plugin name (`type`; empty for `<scene>`).
    pub plugin: String,
    /// `id`, if any.
    pub id: Option<String>,
    /// `name`: the property name its parent receives it under.
    pub name: Option<String>,
    /// Where it was written.
    pub at: Location,
    /// Properties in document order.
    pub properties: Vec<Property>,
    /// Nested objects and references, in document order.
    pub children: Vec<Child>,
}

/// A nested object or a reference to one.
#[derive(Clone, Debug)]
pub enum Child {
    /// An object written in place.
    Object(Object),
    /// `<ref id="..." name="..."/>`.
    Ref {
        /// The object referred to.
        id: String,
        /// Property name, if given.
        name: Option<String>,
        /// Where the reference was written.
        at: Location,
    },
}

/// A named property value.
#[derive(Clone, Debug)]
pub struct Property {
    /// Name (snake_case after the upgrade of old files).
    pub name: String,
    /// Value.
    pub value: Value,
    /// Where it was written.
    pub at: Location,
}

/// A property's typed value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `<float>`.
    Float(f64),
    /// `<integer>`.
    Integer(i64),
    /// `<boolean>`.
    Boolean(bool),
    /// `<string>`.
    String(String),
    /// `<rgb>`.
    Rgb(DVec3),
    /// `<spectrum value="v"/>`: a uniform spectrum.
    Spectrum(f64),
    /// `<point>` or `<vector>`.
    Vector(DVec3),
    /// `<transform>`: the composed matrix.
    Transform(DMat4),
}

impl Value {
    /// The tag that writes this kind of value, for messages.
    pub fn kind(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) => "spectrum",
            Value::Vector(_) => "point/vector",
            Value::Transform(_) => "transform",
        }
    }
}

/// A parsed document: the root object, the search path of `<path>`
/// elements, and every `id` in it.
pub struct Document {
    /// The root (`<scene>`, or any object).
    pub root: Object,
    /// Folders filenames are looked up in after the main file's own.
    pub search_path: Vec<PathBuf>,
    /// Parameters given by the caller (`-D`) that no attribute used.
    pub unused_parameters: Vec<String>,
}

/// Reads `path` and every file it includes. `parameters` are the caller's
/// `-D name=value` pairs, which win over `<default>`s.
pub fn parse(
    path: &Path,
    parameters: &[(String, String)],
    policy: &ReferencePolicy,
) -> Result<Document, SceneError> {
    let mut parser = Parser {
        parameters: parameters
            .iter()
            .map(|(k, v)| Parameter {
                key: k.clone(),
                value: v.clone(),
                used: false,
            })
            .collect(),
        search_path: Vec::new(),
        policy,
        include_depth: 0,
    };
    for p in &parser.parameters {
        if !valid_parameter_name(&p.key) {
            return Err(SceneError::invalid(
                path,
                "-D",
                format!(
                    "parameter name {} must be letters, digits and _",
                    quoted(&p.key)
                ),
            ));
        }
    }
    let mut roots = parser.file(path, true)?;
    let root = match roots.pop() {
        Some(Item::Object(o)) if roots.is_empty() => o,
        _ => return Err(SceneError::malformed(path, "the file holds no object")),
    };
    Ok(Document {
        root,
        search_path: parser.search_path,
        unused_parameters: parser
            .parameters
            .iter()
            .filter(|p| !p.used)
            .map(|p| p.key.clone())
            .collect(),
    })
}

/// A parameter (`-D` or `<default>`).
struct Parameter {
    key: String,
    value: String,
    used: bool,
}

struct Parser<'a> {
    parameters: Vec<Parameter>,
    search_path: Vec<PathBuf>,
    policy: &'a ReferencePolicy,
    include_depth: usize,
}

/// What an element contributes to its parent.
enum Item {
    Object(Object),
    Ref {
        id: String,
        name: Option<String>,
        at: Location,
    },
    Property(Property),
    /// `<default>`, `<path>`, comments: nothing.
    Nothing,
    /// An included `<scene>`: its children, spliced in.
    Splice(Vec<Item>),
}

/// One element's attributes after substitution.
struct Attributes {
    pairs: Vec<(String, String)>,
}

impl Attributes {
    fn get(&self, name: &str) -> Option<&str> {
        self.pairs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }
}

impl Parser<'_> {
    /// The items of file `path`: its root element, or with an included
    /// `<scene>`, the root's children.
    fn file(&mut self, path: &Path, main: bool) -> Result<Vec<Item>, SceneError> {
        let size = std::fs::metadata(path)
            .map_err(|e| SceneError::io(path, e))?
            .len();
        if size > MAX_FILE_BYTES {
            return Err(SceneError::malformed(
                path,
                format!("{size} bytes: an XML scene larger than {MAX_FILE_BYTES} bytes is refused"),
            ));
        }
        let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
        let text = String::from_utf8(bytes)
            .map_err(|e| SceneError::malformed(path, format!("not UTF-8 text: {e}")))?;
        let options = roxmltree::ParsingOptions {
            allow_dtd: false,
            nodes_limit: MAX_NODES,
            ..roxmltree::ParsingOptions::default()
        };
        let doc = roxmltree::Document::parse_with_options(&text, options)
            .map_err(|e| SceneError::malformed(path, format!("XML: {e}")))?;
        let file = Rc::new(path.to_path_buf());
        let root = doc.root_element();
        let at = location(&file, root);
        let version = root.attribute("version").ok_or_else(|| {
            SceneError::invalid(
                path,
                element_name(&at, root.tag_name().name(), ""),
                "the root needs a version attribute (e.g. version=\"3.0.0\")",
            )
        })?;
        let upgrade = parse_version(version).map_err(|e| {
            SceneError::invalid(path, element_name(&at, root.tag_name().name(), ""), e)
        })? < (2, 0, 0);
        let item = self.element(root, &file, upgrade, 0, true)?;
        Ok(match item {
            Item::Object(o) if o.tag == "scene" && !main => o
                .children
                .into_iter()
                .map(|c| match c {
                    Child::Object(o) => Item::Object(o),
                    Child::Ref { id, name, at } => Item::Ref { id, name, at },
                })
                .chain(o.properties.into_iter().map(Item::Property))
                .collect(),
            other => vec![other],
        })
    }

    /// One element and everything under it.
    fn element(
        &mut self,
        node: roxmltree::Node,
        file: &Rc<PathBuf>,
        upgrade: bool,
        depth: usize,
        is_root: bool,
    ) -> Result<Item, SceneError> {
        let at = location(file, node);
        let tag = node.tag_name().name().to_owned();
        let error = |message: String| {
            SceneError::invalid(file.as_path(), element_name(&at, &tag, ""), message)
        };
        if depth > MAX_DEPTH {
            return Err(error(format!("elements nest deeper than {MAX_DEPTH}")));
        }
        let attributes = self.substitute(node, file, &at, &tag)?;
        let attr = |name: &str| attributes.get(name);
        let property_name = |upgrade: bool| -> Result<String, SceneError> {
            let name = attr("name").ok_or_else(|| error("needs a name attribute".into()))?;
            Ok(if upgrade {
                snake_case(name)
            } else {
                name.to_owned()
            })
        };
        match tag.as_str() {
            t if OBJECT_TAGS.contains(&t) => {
                let plugin = attr("type").unwrap_or_default().to_owned();
                if plugin.is_empty() && t != "scene" {
                    return Err(error("needs a type attribute".into()));
                }
                let mut object = Object {
                    tag: tag.clone(),
                    plugin,
                    id: attr("id").map(str::to_owned),
                    name: attr("name").map(|n| if upgrade { snake_case(n) } else { n.to_owned() }),
                    at: at.clone(),
                    properties: Vec::new(),
                    children: Vec::new(),
                };
                for child in node.children().filter(|c| c.is_element()) {
                    let item = self.element(child, file, upgrade, depth + 1, false)?;
                    push_item(&mut object, item, upgrade);
                }
                Ok(Item::Object(object))
            }
            "ref" => Ok(Item::Ref {
                id: attr("id")
                    .ok_or_else(|| error("needs an id attribute".into()))?
                    .to_owned(),
                name: attr("name").map(|n| if upgrade { snake_case(n) } else { n.to_owned() }),
                at,
            }),
            "default" => {
                let name = attr("name").ok_or_else(|| error("needs a name attribute".into()))?;
                let value = attr("value").ok_or_else(|| error("needs a value attribute".into()))?;
                if !valid_parameter_name(name) {
                    return Err(error(format!(
                        "parameter name {} must be letters, digits and _",
                        quoted(name)
                    )));
                }
                if !self.parameters.iter().any(|p| p.key == name) {
                    self.parameters.push(Parameter {
                        key: name.to_owned(),
                        value: value.to_owned(),
                        // A default no attribute uses is no mistake.
                        used: true,
                    });
                }
                Ok(Item::Nothing)
            }
            "path" => {
                if depth != 1 {
                    return Err(error("<path> is allowed only directly under the root".into()));
                }
                let value = attr("value").ok_or_else(|| error("needs a value attribute".into()))?;
                let dir = file.parent().unwrap_or(Path::new(".")).join(value);
                self.search_path.insert(0, dir);
                Ok(Item::Nothing)
            }
            "include" => {
                let filename = attr("filename")
                    .ok_or_else(|| error("needs a filename attribute".into()))?;
                if self.include_depth >= MAX_INCLUDE_DEPTH {
                    return Err(error(format!(
                        "includes nest deeper than {MAX_INCLUDE_DEPTH}"
                    )));
                }
                let target = self.policy.resolve(
                    file.as_path(),
                    &element_name(&at, &tag, ""),
                    filename,
                )?;
                self.include_depth += 1;
                let items = self.file(&target, false);
                self.include_depth -= 1;
                let mut items = items?;
                if let (Some(Item::Object(o)), Some(name)) = (items.first_mut(), attr("name")) {
                    o.name = Some(name.to_owned());
                }
                Ok(Item::Splice(items))
            }
            "alias" => Err(SceneError::unsupported(
                file.as_path(),
                format!("{}: <alias> is not supported; use <ref>", element_name(&at, &tag, "")),
            )),
            "float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" | "point"
            | "vector" | "transform"
                if !is_root =>
            {
                let name = property_name(upgrade)?;
                let value = if tag == "transform" {
                    Value::Transform(self.transform(node, file, depth)?)
                } else {
                    if tag == "spectrum" && attr("type").is_some() {
                        return Err(SceneError::unsupported(
                            file.as_path(),
                            format!(
                                "{}: spectrum textures (type=\"{}\") are not supported",
                                element_name(&at, &tag, ""),
                                attr("type").unwrap_or_default()
                            ),
                        ));
                    }
                    property_value(&tag, &attributes).map_err(error)?
                };
                Ok(Item::Property(Property { name, value, at }))
            }
            _ => Err(error(
                "unknown element (expected an object such as <shape> or <bsdf>, a property such as <float>, or <ref>, <default>, <include>, <path>)"
                .into())),
        }
    }

    /// The matrix of a `<transform>`: each child operation left-multiplied
    /// onto the running matrix (note §1.3, measured).
    fn transform(
        &mut self,
        node: roxmltree::Node,
        file: &Rc<PathBuf>,
        depth: usize,
    ) -> Result<DMat4, SceneError> {
        let mut m = DMat4::IDENTITY;
        for child in node.children().filter(|c| c.is_element()) {
            let at = location(file, child);
            let tag = child.tag_name().name().to_owned();
            if depth + 1 > MAX_DEPTH {
                return Err(SceneError::invalid(
                    file.as_path(),
                    element_name(&at, &tag, ""),
                    format!("elements nest deeper than {MAX_DEPTH}"),
                ));
            }
            let attributes = self.substitute(child, file, &at, &tag)?;
            let op = transform::operation(&tag, |name| attributes.get(name))
                .map_err(|e| SceneError::invalid(file.as_path(), element_name(&at, &tag, ""), e))?;
            m = op * m;
        }
        Ok(m)
    }

    /// The element's attributes with `$name` replaced (longest name first,
    /// note §1.4), `\$` unescaped; a `$` left over is an undefined parameter.
    fn substitute(
        &mut self,
        node: roxmltree::Node,
        file: &Rc<PathBuf>,
        at: &Location,
        tag: &str,
    ) -> Result<Attributes, SceneError> {
        let mut order: Vec<usize> = (0..self.parameters.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(self.parameters[i].key.len()));
        let mut pairs = Vec::new();
        for a in node.attributes() {
            let mut value = a.value().to_owned();
            if value.contains('$') {
                for &i in &order {
                    let p = &mut self.parameters[i];
                    let pattern = format!("${}", p.key);
                    if value.contains(&pattern) {
                        value = replace_unescaped(&value, &pattern, &p.value);
                        p.used = true;
                    }
                }
                if let Some(rest) = unescaped_dollar(&value) {
                    let name: String = rest
                        .chars()
                        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                        .collect();
                    return Err(SceneError::invalid(
                        file.as_path(),
                        element_name(at, tag, ""),
                        format!("undefined parameter ${name} in attribute {}", a.name()),
                    ));
                }
                value = value.replace("\\$", "$");
            }
            pairs.push((a.name().to_owned(), value));
        }
        Ok(Attributes { pairs })
    }
}

/// Adds what an element gave to its parent object.
fn push_item(object: &mut Object, item: Item, upgrade: bool) {
    match item {
        Item::Object(o) => object.children.push(Child::Object(o)),
        Item::Ref { id, name, at } => object.children.push(Child::Ref { id, name, at }),
        Item::Property(mut p) => {
            // Mitsuba 0.6's diffuse called its albedo diffuse_reflectance
            // (note §1.6, step 2).
            if upgrade && object.plugin == "diffuse" && p.name == "diffuse_reflectance" {
                p.name = "reflectance".into();
            }
            object.properties.push(p);
        }
        Item::Nothing => {}
        Item::Splice(items) => {
            for item in items {
                push_item(object, item, upgrade);
            }
        }
    }
}

/// The value of a property element (not a transform).
fn property_value(tag: &str, attributes: &Attributes) -> Result<Value, String> {
    let value = || attributes.get("value").ok_or("needs a value attribute");
    Ok(match tag {
        "float" => Value::Float(parse_f64(value()?)?),
        "integer" => {
            Value::Integer(value()?.trim().parse().map_err(|_| {
                format!("{} is not an integer", quoted(value().unwrap_or_default()))
            })?)
        }
        "boolean" => Value::Boolean(match value()?.trim().to_ascii_lowercase().as_str() {
            "true" => true,
            "false" => false,
            _ => return Err(format!("{} is not true or false", quoted(value()?))),
        }),
        "string" => Value::String(value()?.to_owned()),
        "rgb" => Value::Rgb(triple(value()?)?),
        "spectrum" => {
            if attributes.get("filename").is_some() {
                return Err("spectra from files (filename) are not supported: give an rgb".into());
            }
            let v = value()?;
            if v.contains(':') {
                return Err(format!(
                    "wavelength:value spectra ({}) are not supported: give an rgb or one value",
                    quoted(v)
                ));
            }
            Value::Spectrum(parse_f64(v)?)
        }
        "point" | "vector" => match attributes.get("value") {
            Some(v) => Value::Vector(triple(v)?),
            None => {
                let c = |k: &str| {
                    attributes
                        .get(k)
                        .ok_or_else(|| {
                            format!("needs a value attribute or all of x, y, z ({k} is missing)")
                        })
                        .and_then(parse_f64)
                };
                Value::Vector(DVec3::new(c("x")?, c("y")?, c("z")?))
            }
        },
        _ => unreachable!("property tags are matched by the caller"),
    })
}

/// `major.minor.patch`, each part a number.
fn parse_version(s: &str) -> Result<(u32, u32, u32), String> {
    let parts: Vec<Option<u32>> = s.trim().split('.').map(|p| p.parse().ok()).collect();
    match parts.as_slice() {
        [Some(a), Some(b), Some(c)] => Ok((*a, *b, *c)),
        _ => Err(format!(
            "version {} is not major.minor.patch (Mitsuba 0.6 files: \"0.6.0\")",
            quoted(s)
        )),
    }
}

/// Mitsuba's upgrade of property names in files before 2.0.0 (note §1.6):
/// where a lower-case letter meets an upper-case one, insert `_` and lower
/// that letter and the upper-case letters right after it (`toWorld` ->
/// `to_world`, `intIOR` -> `int_ior`).
pub fn snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        out.push(c);
        i += 1;
        if c.is_ascii_lowercase() && i < chars.len() && chars[i].is_ascii_uppercase() {
            out.push('_');
            while i < chars.len() && chars[i].is_ascii_uppercase() {
                out.push(chars[i].to_ascii_lowercase());
                i += 1;
            }
        }
    }
    out
}

fn valid_parameter_name(name: &str) -> bool {
    !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// `value` with every `pattern` not preceded by a backslash replaced.
fn replace_unescaped(value: &str, pattern: &str, with: &str) -> String {
    let mut out = String::with_capacity(value.len());
    let mut rest = value;
    while let Some(i) = rest.find(pattern) {
        let escaped = rest[..i].ends_with('\\');
        out.push_str(&rest[..i]);
        out.push_str(if escaped { pattern } else { with });
        rest = &rest[i + pattern.len()..];
    }
    out.push_str(rest);
    out
}

/// The text after the first `$` not preceded by a backslash.
fn unescaped_dollar(value: &str) -> Option<&str> {
    value
        .match_indices('$')
        .find(|(i, _)| !value[..*i].ends_with('\\'))
        .map(|(i, _)| &value[i + 1..])
}

fn location(file: &Rc<PathBuf>, node: roxmltree::Node) -> Location {
    Location {
        file: file.clone(),
        line: node.document().text_pos_at(node.range().start).row,
    }
}

/// `line 12: <bsdf type="diffuse">` for messages.
pub fn element_name(at: &Location, tag: &str, plugin: &str) -> String {
    if plugin.is_empty() {
        format!("line {}: <{tag}>", at.line)
    } else {
        format!("line {}: <{tag} type={}>", at.line, quoted(plugin))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_names_are_upgraded_as_mitsuba_does() {
        for (old, new) in [
            ("toWorld", "to_world"),
            ("intIOR", "int_ior"),
            ("maxDepth", "max_depth"),
            ("sampleCount", "sample_count"),
            ("specularReflectance", "specular_reflectance"),
            ("alphaU", "alpha_u"),
            ("fov", "fov"),
            ("shapeIndex", "shape_index"),
        ] {
            assert_eq!(snake_case(old), new);
        }
    }

    #[test]
    fn substitution_and_escapes() {
        assert_eq!(replace_unescaped("$a, $ab", "$ab", "X"), "$a, X");
        assert_eq!(replace_unescaped("\\$a $a", "$a", "1"), "\\$a 1");
        assert_eq!(unescaped_dollar("\\$a"), None);
        assert_eq!(unescaped_dollar("x $r"), Some("r"));
        assert_eq!(triple("0.1\n0.2\t0.3").unwrap(), DVec3::new(0.1, 0.2, 0.3));
        assert_eq!(triple("2").unwrap(), DVec3::splat(2.0));
        assert!(triple("1, 2").is_err());
        assert!(parse_f64("1.5x").is_err());
        assert_eq!(parse_version("0.6.0"), Ok((0, 6, 0)));
        assert!(parse_version("0.6").is_err());
    }
}
