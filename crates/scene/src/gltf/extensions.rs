//! glTF extensions: which ones this loader implements, and what a file that
//! uses others is told (glTF 2.0 spec §3.12: a loader must refuse a file whose
//! `extensionsRequired` names an extension it does not support, and may
//! ignore the ones only listed in `extensionsUsed`).

use std::path::Path;

use gltf::json::Root;
use serde_json::Value;

use crate::error::{SceneError, quoted};

/// The extensions whose data this loader reads (see the `material` module
/// docs for how each one maps).
pub const SUPPORTED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
];

/// At most this many material names are listed per ignored extension, so a
/// warning stays one line on files with hundreds of materials.
const MAX_NAMED_MATERIALS: usize = 4;

/// Refuses a file that requires an extension outside [`SUPPORTED`], naming it.
pub(super) fn check_required(path: &Path, root: &Root) -> Result<(), SceneError> {
    match root
        .extensions_required
        .iter()
        .find(|e| !SUPPORTED.contains(&e.as_str()))
    {
        Some(e) => Err(SceneError::unsupported(
            path,
            format!(
                "the file requires extension {} (extensionsRequired), which this renderer does not implement (it implements {})",
                quoted(e),
                SUPPORTED.join(", ")
            ),
        )),
        None => Ok(()),
    }
}

/// One line per extension in `extensionsUsed` outside [`SUPPORTED`], naming
/// the materials that carry it (where it is a material extension): its data
/// is ignored and the image may differ from what the author meant.
pub(super) fn ignored(root: &Root) -> Vec<String> {
    root.extensions_used
        .iter()
        .filter(|e| !SUPPORTED.contains(&e.as_str()))
        .map(|e| {
            let users = materials_using(root, e);
            let named: Vec<String> = users.iter().take(MAX_NAMED_MATERIALS).cloned().collect();
            let more = users.len().saturating_sub(MAX_NAMED_MATERIALS);
            let whom = match (named.is_empty(), more) {
                (true, _) => String::new(),
                (false, 0) => format!(" by material {}", named.join(", ")),
                (false, n) => format!(" by material {} and {n} more", named.join(", ")),
            };
            format!(
                "glTF extension {} (used{whom}) is not supported: its data is ignored",
                quoted(e)
            )
        })
        .collect()
}

/// Names (or `#index`) of the materials whose JSON mentions `extension`
/// anywhere (the material itself or one of its texture references).
fn materials_using(root: &Root, extension: &str) -> Vec<String> {
    root.materials
        .iter()
        .enumerate()
        .filter(|(_, m)| serde_json::to_value(m).is_ok_and(|v| mentions(&v, extension)))
        .map(|(i, m)| m.name.as_deref().map_or(format!("#{i}"), quoted))
        .collect()
}

/// True when `value` has an `extensions` object with key `extension` at any depth.
fn mentions(value: &Value, extension: &str) -> bool {
    match value {
        Value::Object(map) => {
            map.get("extensions")
                .and_then(Value::as_object)
                .is_some_and(|e| e.contains_key(extension))
                || map.values().any(|v| mentions(v, extension))
        }
        Value::Array(items) => items.iter().any(|v| mentions(v, extension)),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root(json: &str) -> Root {
        serde_json::from_str(json).unwrap()
    }

    #[test]
    fn ignored_extensions_name_their_materials() {
        let r = root(
            r#"{"asset":{"version":"2.0"},
                "extensionsUsed":["KHR_materials_clearcoat","KHR_materials_ior","EXT_x"],
                "materials":[
                  {"name":"paint","extensions":{"KHR_materials_clearcoat":{"clearcoatFactor":1}}},
                  {"name":"plain"},
                  {"pbrMetallicRoughness":{"baseColorTexture":{"index":0,
                     "extensions":{"KHR_materials_clearcoat":{}}}}}]}"#,
        );
        let lines = ignored(&r);
        assert_eq!(lines.len(), 2, "{lines:?}");
        assert!(lines[0].contains("\"KHR_materials_clearcoat\""));
        assert!(lines[0].contains("\"paint\", #2"), "{}", lines[0]);
        assert!(!lines[0].contains("plain"));
        assert!(lines[1].contains("\"EXT_x\"") && !lines[1].contains("by material"));
    }

    #[test]
    fn a_required_unsupported_extension_is_an_error_naming_it() {
        let r = root(
            r#"{"asset":{"version":"2.0"},"extensionsUsed":["KHR_draco_mesh_compression"],
                "extensionsRequired":["KHR_draco_mesh_compression"]}"#,
        );
        let e = check_required(Path::new("m.gltf"), &r)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.gltf") && e.contains("KHR_draco_mesh_compression"),
            "{e}"
        );
        let ok = root(r#"{"asset":{"version":"2.0"},"extensionsRequired":["KHR_materials_ior"]}"#);
        assert!(check_required(Path::new("m.gltf"), &ok).is_ok());
    }
}
