//! glTF 2.0 (`.gltf` JSON with external or data-URI resources) and GLB.
//!
//! The `gltf` crate parses and validates the document and decodes accessors. Everything the
//! document references (buffers, images) is read here, through the caller's resolver, and only
//! base-colour images are decoded. The crate trusts a validated document further than is safe
//! (its accessor reader panics on layouts it does not expect and on out-of-range arithmetic, its
//! validator indexes the POSITION accessor unchecked), so those things are checked here first.

use std::borrow::Cow;
use std::collections::{HashMap, HashSet};
use std::path::Path;

use base64::Engine as _;
use base64::engine::DecodePaddingMode;
use base64::engine::general_purpose::{GeneralPurpose, GeneralPurposeConfig};
use glam::{Mat3, Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::buffer::Source;
use gltf::json::Value;
use gltf::json::validation::Checked;
use gltf::mesh::Mode;
use gltf::texture::{MagFilter, WrappingMode};
use gltf::{Accessor, Document, Semantic};

use crate::builder::MeshBuilder;
use crate::texture::TextureBudget;
use crate::{AlphaMode, ErrorKind, Limits, Material, MeshError, Resolver, Texture, Wrap, texture};

/// Extensions that change what the geometry is: loading without them would be silently wrong,
/// so a file that uses one is refused even when it only lists it as used.
const GEOMETRY_EXTENSIONS: [&str; 3] = [
    "KHR_draco_mesh_compression",
    "KHR_meshopt_compression",
    "EXT_mesh_gpu_instancing",
];

/// Extensions this loader implements, all three written by gltfpack: integer vertex
/// attributes, meshoptimizer-compressed buffer views, and the texture-coordinate transform
/// that undoes quantized texture coordinates (honoured on the base-colour texture).
const IMPLEMENTED_EXTENSIONS: [&str; 3] = [
    "KHR_mesh_quantization",
    "EXT_meshopt_compression",
    "KHR_texture_transform",
];

/// Most bytes that `EXT_meshopt_compression` may make one model decode into (its fallback
/// buffers): a compressed view costs memory in proportion to what it declares, not to its
/// file bytes. The default limits' vertices and triangles need well under this.
const MAX_DECODED_BYTES: usize = 1 << 30;

/// Most elements accepted in a sparse accessor without a buffer view. Such an accessor costs
/// memory per element but no file bytes, so its declared count alone would size allocations.
const MAX_UNBACKED_ELEMENTS: usize = 1 << 24;

/// glTF's default alpha cutoff for `MASK` materials.
const DEFAULT_ALPHA_CUTOFF: f32 = 0.5;

/// Element layouts accepted for each attribute: floats, which the gltf reader decodes, and the
/// integers KHR_mesh_quantization allows, which [`Loader::read_integers`] does (the reader
/// panics on layouts it does not expect).
const POSITION_LAYOUTS: &[(DataType, Dimensions)] = &[
    (DataType::F32, Dimensions::Vec3),
    (DataType::I8, Dimensions::Vec3),
    (DataType::U8, Dimensions::Vec3),
    (DataType::I16, Dimensions::Vec3),
    (DataType::U16, Dimensions::Vec3),
];
const NORMAL_LAYOUTS: &[(DataType, Dimensions)] = &[
    (DataType::F32, Dimensions::Vec3),
    (DataType::I8, Dimensions::Vec3),
    (DataType::I16, Dimensions::Vec3),
];
const TEX_COORD_LAYOUTS: &[(DataType, Dimensions)] = &[
    (DataType::F32, Dimensions::Vec2),
    (DataType::I8, Dimensions::Vec2),
    (DataType::U8, Dimensions::Vec2),
    (DataType::I16, Dimensions::Vec2),
    (DataType::U16, Dimensions::Vec2),
];
const COLOR_LAYOUTS: &[(DataType, Dimensions)] = &[
    (DataType::F32, Dimensions::Vec3),
    (DataType::F32, Dimensions::Vec4),
    (DataType::U8, Dimensions::Vec3),
    (DataType::U8, Dimensions::Vec4),
    (DataType::U16, Dimensions::Vec3),
    (DataType::U16, Dimensions::Vec4),
];
const INDEX_LAYOUTS: &[(DataType, Dimensions)] = &[
    (DataType::U8, Dimensions::Scalar),
    (DataType::U16, Dimensions::Scalar),
    (DataType::U32, Dimensions::Scalar),
];

/// Base64 as exporters write it: standard alphabet, padding optional.
const BASE64: GeneralPurpose = GeneralPurpose::new(
    &base64::alphabet::STANDARD,
    GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
);

pub(crate) fn load(
    path: &Path,
    bytes: &[u8],
    limits: &Limits,
    resolver: &mut Resolver<'_>,
    warnings: &mut Vec<String>,
) -> Result<MeshBuilder, MeshError> {
    load_document(bytes, limits, resolver, warnings).map_err(|kind| kind.in_file(path))
}

fn load_document(
    bytes: &[u8],
    limits: &Limits,
    resolver: &mut Resolver<'_>,
    warnings: &mut Vec<String>,
) -> Result<MeshBuilder, ErrorKind> {
    // Sniffed like the gltf crate does, so a GLB named `.gltf` still loads.
    let (json, blob) = if bytes.starts_with(b"glTF") {
        split_glb(bytes)?
    } else {
        (bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes), None)
    };
    // The raw JSON is kept for what the typed model hides with its extension features off.
    let raw: Value = gltf::json::deserialize::from_slice(json)
        .map_err(|e| corrupt(format!("invalid glTF JSON: {e}")))?;
    check_geometry_extensions(&raw)?;
    let document = parse_document(json, &raw, warnings)?;
    let files = files_read(&document);
    if !files.is_empty() {
        resolver.will_read(&files);
    }
    let mut buffers = load_buffers(&document, &raw, blob, resolver)?;
    decode_meshopt_views(&document, &raw, &mut buffers)?;
    let draws = scene_draws(&document, warnings)?;

    let mut loader = Loader {
        document: &document,
        raw: &raw,
        buffers: &buffers,
        resolver,
        warnings,
        builder: MeshBuilder::default(),
        materials: vec![None; document.materials().len()],
        default_material: None,
        textures: HashMap::new(),
        decoded_images: HashMap::new(),
        budget: TextureBudget::new(limits),
        limits: *limits,
        warned: HashSet::new(),
        skipped_primitives: false,
    };
    for (mesh, world) in &draws {
        loader.add_mesh(mesh, *world)?;
    }
    if loader.builder.triangles.is_empty() {
        let why = if draws.is_empty() {
            " (the scene draws no meshes)"
        } else if loader.skipped_primitives {
            " (its primitives are points or lines)"
        } else {
            ""
        };
        return Err(ErrorKind::Empty(why.to_string()));
    }
    Ok(loader.builder)
}

fn corrupt(message: impl Into<String>) -> ErrorKind {
    ErrorKind::Corrupt(message.into())
}

/// Names an object in messages: by its name when it has one (mesh `Duck`), else by index
/// (mesh 3).
fn label(kind: &str, name: Option<&str>, index: usize) -> String {
    match name {
        Some(name) => format!("{kind} `{name}`"),
        None => format!("{kind} {index}"),
    }
}

fn le_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let word = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes(word.try_into().ok()?))
}

/// Splits a GLB container into its JSON chunk and optional BIN chunk. Done here rather than by
/// `gltf::Glb`, which underflows (panics) on a header length under 12 and reports truncation
/// without saying so.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), ErrorKind> {
    let (Some(version), Some(length)) = (le_u32(bytes, 4), le_u32(bytes, 8)) else {
        return Err(corrupt(format!(
            "truncated GLB: {} bytes, shorter than the 12-byte header",
            bytes.len()
        )));
    };
    if version != 2 {
        return Err(corrupt(format!(
            "unsupported GLB version {version} (expected 2)"
        )));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(corrupt(format!(
            "truncated GLB: the header declares {length} bytes, the file has {}",
            bytes.len()
        )));
    }
    let mut rest = bytes.get(12..length).ok_or_else(|| {
        corrupt(format!(
            "invalid GLB: declared length {length} is shorter than its header"
        ))
    })?;
    let (mut json, mut bin) = (None, None);
    while !rest.is_empty() {
        let chunk = if json.is_none() { "JSON" } else { "binary" };
        let (Some(chunk_length), Some(kind)) = (le_u32(rest, 0), rest.get(4..8)) else {
            return Err(corrupt(format!(
                "truncated GLB: incomplete {chunk} chunk header"
            )));
        };
        let end = (chunk_length as usize).checked_add(8);
        let Some((data, tail)) = end.and_then(|end| rest.get(8..end).zip(rest.get(end..))) else {
            return Err(corrupt(format!(
                "truncated GLB: the {chunk} chunk declares {chunk_length} bytes, {} remain",
                rest.len() - 8
            )));
        };
        match kind {
            _ if json.is_none() && kind != b"JSON" => {
                return Err(corrupt("invalid GLB: the first chunk is not JSON"));
            }
            b"JSON" if json.is_none() => json = Some(data),
            b"BIN\0" if bin.is_none() => bin = Some(data),
            // The specification asks readers to skip chunks they do not know.
            _ => {}
        }
        rest = tail;
    }
    let json = json.ok_or_else(|| corrupt("invalid GLB: no JSON chunk"))?;
    Ok((json, bin))
}

/// Refuses files whose geometry needs an extension this loader does not implement.
fn check_geometry_extensions(raw: &Value) -> Result<(), ErrorKind> {
    let listed = |key: &str| {
        raw.get(key)
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
            .filter_map(Value::as_str)
    };
    match listed("extensionsRequired")
        .chain(listed("extensionsUsed"))
        .find(|name| GEOMETRY_EXTENSIONS.contains(name))
    {
        Some(name) => Err(ErrorKind::UnsupportedExtension(name.to_string())),
        None => Ok(()),
    }
}

/// Deserialises and validates the document. Required extensions left after the geometry check
/// only affect appearance, so they are dropped with a warning instead of failing validation
/// (the gltf crate refuses every required extension whose feature is not compiled in).
fn parse_document(
    json: &[u8],
    raw: &Value,
    warnings: &mut Vec<String>,
) -> Result<Document, ErrorKind> {
    let mut root: gltf::json::Root = gltf::json::deserialize::from_slice(json)
        .map_err(|e| corrupt(format!("invalid glTF: {e}")))?;
    for name in root.extensions_required.drain(..) {
        if IMPLEMENTED_EXTENSIONS.contains(&name.as_str()) {
            continue;
        }
        warnings.push(format!(
            "required extension `{name}` is not supported; loading without it"
        ));
    }
    // A texture whose image is only in an extension (KHR_texture_basisu, EXT_texture_webp, ...)
    // takes that image, so it is reported as a format the loader cannot read, not as damage.
    for (t, texture) in root.textures.iter_mut().enumerate() {
        if texture.source.value() == u32::MAX as usize
            && let Some(image) = raw
                .pointer(&format!("/textures/{t}/extensions"))
                .and_then(Value::as_object)
                .and_then(|extensions| {
                    extensions
                        .values()
                        .find_map(|e| e.get("source").and_then(Value::as_u64))
                })
                .and_then(|image| u32::try_from(image).ok())
        {
            texture.source = gltf::json::Index::new(image);
        }
    }
    // The validator indexes the POSITION accessor without a bounds check.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive
                .attributes
                .get(&Checked::Valid(Semantic::Positions))
                && root.accessors.get(index.value()).is_none()
            {
                return Err(corrupt(format!(
                    "invalid glTF: mesh {m} primitive {p}: POSITION accessor {} does not exist",
                    index.value()
                )));
            }
        }
    }
    Document::from_json(root).map_err(|error| match error {
        gltf::Error::Validation(errors) => {
            const SHOWN: usize = 3;
            let mut message = errors
                .iter()
                .take(SHOWN)
                .map(|(path, e)| format!("{path}: {e}"))
                .collect::<Vec<_>>()
                .join("; ");
            if errors.len() > SHOWN {
                message += &format!(" (and {} more)", errors.len() - SHOWN);
            }
            corrupt(format!("invalid glTF: {message}"))
        }
        other => corrupt(format!("invalid glTF: {other}")),
    })
}

/// The bytes of every buffer, each at least as long as it declares. An `EXT_meshopt_compression`
/// fallback buffer without a uri starts as zeros: its compressed views are decoded into it.
fn load_buffers<'a>(
    document: &Document,
    raw: &Value,
    blob: Option<&'a [u8]>,
    resolver: &mut Resolver<'_>,
) -> Result<Vec<Cow<'a, [u8]>>, ErrorKind> {
    let mut fallback_bytes = 0usize;
    document
        .buffers()
        .map(|buffer| {
            let index = buffer.index();
            let fallback = raw
                .pointer(&format!(
                    "/buffers/{index}/extensions/EXT_meshopt_compression/fallback"
                ))
                .and_then(Value::as_bool)
                == Some(true);
            let data = match buffer.source() {
                Source::Bin if fallback => {
                    fallback_bytes = fallback_bytes.saturating_add(buffer.length());
                    if fallback_bytes > MAX_DECODED_BYTES {
                        return Err(corrupt(format!(
                            "EXT_meshopt_compression: the fallback buffers declare more than \
                             {MAX_DECODED_BYTES} bytes to decode"
                        )));
                    }
                    Cow::Owned(vec![0; buffer.length()])
                }
                Source::Bin => Cow::Borrowed(blob.ok_or_else(|| {
                    corrupt(format!(
                        "buffer {} has no uri and there is no GLB binary chunk",
                        buffer.index()
                    ))
                })?),
                Source::Uri(uri) => Cow::Owned(read_uri(uri, resolver)?),
            };
            if data.len() < buffer.length() {
                return Err(corrupt(format!(
                    "buffer {} is truncated: {} bytes, {} declared",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                )));
            }
            Ok(data)
        })
        .collect()
}

/// Decodes every `EXT_meshopt_compression` buffer view into the bytes of its own buffer, so that
/// what follows reads it like any other view. meshoptimizer's decoders are made for untrusted
/// input (they check every read against the compressed bytes and report errors); what they
/// assert instead (element sizes, index counts) is checked here first.
fn decode_meshopt_views(
    document: &Document,
    raw: &Value,
    buffers: &mut [Cow<'_, [u8]>],
) -> Result<(), ErrorKind> {
    // Bytes read and written by the decoders over the whole model: views may share one range,
    // so each view's cost is counted, not the buffers'.
    let mut work = 0usize;
    for view in document.views() {
        let pointer = format!(
            "/bufferViews/{}/extensions/EXT_meshopt_compression",
            view.index()
        );
        let Some(extension) = raw.pointer(&pointer) else {
            continue;
        };
        let context = format!("buffer view {}: EXT_meshopt_compression", view.index());
        let bad = |what: &str| corrupt(format!("{context}: {what}"));
        let number = |key: &str, default: Option<u64>| {
            match extension.get(key) {
                None => default,
                Some(value) => value.as_u64(),
            }
            .and_then(|n| usize::try_from(n).ok())
            .ok_or_else(|| bad(&format!("`{key}` is missing or not a count")))
        };
        let text = |key: &str, default: Option<&'static str>| {
            match extension.get(key) {
                None => default.map(str::to_string),
                Some(value) => value.as_str().map(str::to_string),
            }
            .ok_or_else(|| bad(&format!("`{key}` is missing or not a string")))
        };
        let (source_buffer, offset, length) = (
            number("buffer", None)?,
            number("byteOffset", Some(0))?,
            number("byteLength", None)?,
        );
        let (stride, count) = (number("byteStride", None)?, number("count", None)?);
        let (mode, filter) = (text("mode", None)?, text("filter", Some("NONE"))?);
        if count.checked_mul(stride) != Some(view.length()) {
            return Err(bad(&format!(
                "{count} elements of {stride} bytes are not the view's {} bytes",
                view.length()
            )));
        }
        let target = view.buffer().index();
        let range = view
            .offset()
            .checked_add(view.length())
            .map(|end| view.offset()..end)
            .filter(|range| buffers.get(target).is_some_and(|b| range.end <= b.len()))
            .ok_or_else(|| bad(&format!("the view extends past the end of buffer {target}")))?;
        work = work.saturating_add(view.length()).saturating_add(length);
        if work > MAX_DECODED_BYTES {
            return Err(bad(&format!(
                "the compressed views decode more than {MAX_DECODED_BYTES} bytes"
            )));
        }
        let source = offset
            .checked_add(length)
            .and_then(|end| buffers.get(source_buffer)?.get(offset..end))
            .ok_or_else(|| bad("the compressed bytes lie outside their buffer"))?
            .to_vec();
        // Words, so that the filters, which read 16- and 32-bit values, see aligned data.
        let mut decoded = vec![0u32; view.length().div_ceil(4)];
        let (out, source_len) = (decoded.as_mut_ptr().cast(), source.len());
        // SAFETY: `out` holds at least `count * stride` bytes and `source` is `source_len` bytes long;
        // the decoders read and write nothing else, and every size they assert is checked.
        let status = match (mode.as_str(), filter.as_str()) {
            ("ATTRIBUTES", _) if stride % 4 == 0 && (4..=256).contains(&stride) => unsafe {
                meshopt::ffi::meshopt_decodeVertexBuffer(
                    out,
                    count,
                    stride,
                    source.as_ptr(),
                    source_len,
                )
            },
            ("TRIANGLES", "NONE") if matches!(stride, 2 | 4) && count % 3 == 0 => unsafe {
                meshopt::ffi::meshopt_decodeIndexBuffer(
                    out,
                    count,
                    stride,
                    source.as_ptr(),
                    source_len,
                )
            },
            ("INDICES", "NONE") if matches!(stride, 2 | 4) => unsafe {
                meshopt::ffi::meshopt_decodeIndexSequence(
                    out,
                    count,
                    stride,
                    source.as_ptr(),
                    source_len,
                )
            },
            _ => {
                return Err(bad(&format!(
                    "mode {mode} with filter {filter} and a {stride}-byte stride is not valid"
                )));
            }
        };
        if status != 0 {
            return Err(bad(&format!(
                "the compressed data is corrupt (meshoptimizer error {status})"
            )));
        }
        // SAFETY: as above; each filter's stride requirement is checked first.
        match filter.as_str() {
            "NONE" => {}
            "OCTAHEDRAL" if matches!(stride, 4 | 8) => unsafe {
                meshopt::ffi::meshopt_decodeFilterOct(out, count, stride)
            },
            "QUATERNION" if stride == 8 => unsafe {
                meshopt::ffi::meshopt_decodeFilterQuat(out, count, stride)
            },
            "EXPONENTIAL" => unsafe { meshopt::ffi::meshopt_decodeFilterExp(out, count, stride) },
            _ => {
                return Err(bad(&format!(
                    "filter {filter} does not apply to a {stride}-byte stride"
                )));
            }
        }
        // The words hold the bytes the decoders wrote, in memory order.
        let bytes = &mut buffers[target].to_mut()[range];
        for (into, word) in bytes.chunks_mut(4).zip(&decoded) {
            into.copy_from_slice(&word.to_ne_bytes()[..into.len()]);
        }
    }
    Ok(())
}

/// The files the loader may read, as [`read_uri`] asks for them: the external buffers (as
/// [`load_buffers`] reads them) and the images of base-colour textures, the only images read
/// (their JSON directly, as `Loader::decode_image` reads it). Each image is named once however
/// many materials use it, so the work is linear in the document.
fn files_read(document: &Document) -> Vec<String> {
    let buffers = document.buffers().filter_map(|b| match b.source() {
        Source::Uri(uri) => Some(uri),
        Source::Bin => None,
    });
    let json_images = &document.as_json().images;
    let mut base_colour = vec![false; json_images.len()];
    for info in document
        .materials()
        .filter_map(|m| m.pbr_metallic_roughness().base_color_texture())
    {
        if let Some(used) = base_colour.get_mut(info.texture().source().index()) {
            *used = true;
        }
    }
    let images = json_images
        .iter()
        .zip(base_colour)
        .filter(|(image, used)| *used && image.buffer_view.is_none())
        .filter_map(|(image, _)| image.uri.as_deref());
    let mut seen = HashSet::new();
    buffers
        .chain(images)
        .filter(|uri| !uri.starts_with("data:"))
        .map(file_name)
        .filter(|name| seen.insert(name.clone()))
        .collect()
}

/// Reads what a URI refers to: a file (percent-decoded into a relative name) from the
/// resolver, or a `data:` URI decoded in place.
fn read_uri(uri: &str, resolver: &mut Resolver<'_>) -> Result<Vec<u8>, ErrorKind> {
    let Some(data) = uri.strip_prefix("data:") else {
        return resolver
            .read(&file_name(uri))
            .map_err(|source| ErrorKind::MissingExternal {
                uri: uri.to_string(),
                source,
            });
    };
    let (meta, payload) = data
        .split_once(',')
        .ok_or_else(|| corrupt("invalid data URI: no comma before the data"))?;
    if meta.ends_with(";base64") {
        BASE64
            .decode(payload)
            .map_err(|e| corrupt(format!("invalid base64 in data URI: {e}")))
    } else {
        Ok(percent_decode(payload))
    }
}

/// The file a URI that is not a `data:` URI names, as the resolver is asked for it
/// (percent-decoded).
fn file_name(uri: &str) -> String {
    String::from_utf8_lossy(&percent_decode(uri)).into_owned()
}

/// Decodes `%XX` escapes; anything else, malformed escapes included, passes through.
fn percent_decode(text: &str) -> Vec<u8> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let escaped = (bytes[i] == b'%')
            .then(|| bytes.get(i + 1..i + 3))
            .flatten()
            .and_then(|hex| std::str::from_utf8(hex).ok())
            .and_then(|hex| u8::from_str_radix(hex, 16).ok());
        match escaped {
            Some(byte) => {
                out.push(byte);
                i += 3;
            }
            None => {
                out.push(bytes[i]);
                i += 1;
            }
        }
    }
    out
}

/// Every mesh instance of the scene to draw, with its world transform, in scene order
/// (depth first, children in file order).
fn scene_draws<'d>(
    document: &'d Document,
    warnings: &mut Vec<String>,
) -> Result<Vec<(gltf::Mesh<'d>, Mat4)>, ErrorKind> {
    let roots: Vec<gltf::Node<'d>> = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => scene.nodes().collect(),
        None => {
            warnings.push("the file has no scene; loading every root node".to_string());
            let mut is_child = vec![false; document.nodes().len()];
            for child in document.nodes().flat_map(|node| node.children()) {
                is_child[child.index()] = true;
            }
            document
                .nodes()
                .filter(|node| !is_child[node.index()])
                .collect()
        }
    };
    // An explicit stack, so deep hierarchies cannot overflow the call stack, and a visited set,
    // so cycles (which validation does not catch) cannot loop forever.
    let mut visited = vec![false; document.nodes().len()];
    let mut stack: Vec<(gltf::Node<'d>, Mat4)> = roots
        .into_iter()
        .rev()
        .map(|node| (node, Mat4::IDENTITY))
        .collect();
    let mut draws = Vec::new();
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut visited[node.index()], true) {
            return Err(corrupt(format!(
                "invalid glTF: {} is reached twice in the scene (nodes must form trees)",
                label("node", node.name(), node.index())
            )));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            if node.skin().is_some() {
                warnings.push(format!(
                    "{}: skinning is ignored (the mesh is loaded in its bind pose)",
                    label("node", node.name(), node.index())
                ));
            }
            draws.push((mesh, world));
        }
        let children: Vec<_> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|child| (child, world)));
    }
    Ok(draws)
}

/// A converted material as a primitive uses it: the canonical material, the texture coordinate
/// set its base-colour texture samples and the transform applied to those coordinates.
#[derive(Clone, Copy)]
struct MaterialUse {
    slot: u32,
    uv_set: u32,
    uv_transform: Option<UvTransform>,
}

/// `KHR_texture_transform` on a texture reference: `uv' = offset + rotation(scale * uv)`, the
/// rotation turning +u towards -v (counter-clockwise in glTF's v-down texture space), as the
/// extension's sample model and the engines that render it do; the GLSL listing in the
/// extension's text turns the other way (KhronosGroup/glTF#1563).
#[derive(Clone, Copy)]
struct UvTransform {
    offset: [f32; 2],
    rotation: f32,
    scale: [f32; 2],
}

impl UvTransform {
    /// The transform and the texture coordinate set it overrides (`texCoord`), if it does.
    fn parse(json: &Value) -> Result<(UvTransform, Option<u32>), String> {
        let pair = |key: &str, default: [f32; 2]| match json.get(key) {
            None => Ok(default),
            Some(value) => value
                .as_array()
                .filter(|a| a.len() == 2)
                .and_then(|a| Some([a[0].as_f64()? as f32, a[1].as_f64()? as f32]))
                .filter(|p| p.iter().all(|v| v.is_finite()))
                .ok_or_else(|| format!("`{key}` is not two finite numbers")),
        };
        let rotation = match json.get("rotation") {
            None => 0.0,
            Some(value) => value
                .as_f64()
                .map(|r| r as f32)
                .filter(|r| r.is_finite())
                .ok_or("`rotation` is not a finite number")?,
        };
        let tex_coord = match json.get("texCoord") {
            None => None,
            Some(value) => Some(
                value
                    .as_u64()
                    .and_then(|n| u32::try_from(n).ok())
                    .ok_or("`texCoord` is not a texture coordinate set")?,
            ),
        };
        let transform = UvTransform {
            offset: pair("offset", [0.0, 0.0])?,
            rotation,
            scale: pair("scale", [1.0, 1.0])?,
        };
        Ok((transform, tex_coord))
    }

    fn apply(&self, [u, v]: [f32; 2]) -> [f32; 2] {
        let (u, v) = (u * self.scale[0], v * self.scale[1]);
        let (sin, cos) = self.rotation.sin_cos();
        [
            self.offset[0] + cos * u + sin * v,
            self.offset[1] - sin * u + cos * v,
        ]
    }
}

/// Converts the drawn primitives into the builder, converting materials and decoding
/// textures on first use.
struct Loader<'a, 'r> {
    document: &'a Document,
    raw: &'a Value,
    buffers: &'a [Cow<'a, [u8]>],
    resolver: &'a mut Resolver<'r>,
    warnings: &'a mut Vec<String>,
    builder: MeshBuilder,
    /// How each glTF material is drawn, once converted.
    materials: Vec<Option<MaterialUse>>,
    default_material: Option<u32>,
    /// Canonical texture per (image, sampler) pair.
    textures: HashMap<(usize, Option<usize>), u32>,
    /// A canonical texture holding each decoded image, so an image is decoded only once.
    decoded_images: HashMap<usize, u32>,
    budget: TextureBudget,
    limits: Limits,
    /// Warnings already given, so an instanced mesh does not repeat them.
    warned: HashSet<String>,
    /// Whether any point or line primitive was skipped, to explain an empty result.
    skipped_primitives: bool,
}

impl Loader<'_, '_> {
    fn warn(&mut self, message: String) {
        if self.warned.insert(message.clone()) {
            self.warnings.push(message);
        }
    }

    fn add_mesh(&mut self, mesh: &gltf::Mesh<'_>, world: Mat4) -> Result<(), ErrorKind> {
        let linear = Mat3::from_mat4(world);
        let normal_matrix = linear.inverse().transpose();
        // A mirroring transform turns counter-clockwise triangles clockwise.
        let flip = linear.determinant() < 0.0;
        let mesh_label = label("mesh", mesh.name(), mesh.index());
        for primitive in mesh.primitives() {
            let context = format!("{mesh_label} primitive {}", primitive.index());
            if !matches!(
                primitive.mode(),
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.skipped_primitives = true;
                self.warn(format!(
                    "{context}: {:?} primitive skipped (only triangles are loaded)",
                    primitive.mode()
                ));
                continue;
            }
            if primitive.morph_targets().next().is_some() {
                self.warn(format!(
                    "{context}: morph targets are ignored (base shape loaded)"
                ));
            }
            self.add_primitive(&primitive, &context, world, normal_matrix, flip)?;
        }
        Ok(())
    }

    fn add_primitive(
        &mut self,
        primitive: &gltf::Primitive<'_>,
        context: &str,
        world: Mat4,
        normal_matrix: Mat3,
        flip: bool,
    ) -> Result<(), ErrorKind> {
        let MaterialUse {
            slot: material,
            uv_set,
            uv_transform,
        } = self.material(primitive.material())?;

        let buffers = self.buffers;
        let reader = primitive.reader(|buffer| buffers.get(buffer.index()).map(|data| &data[..]));
        let position_accessor = primitive
            .get(&Semantic::Positions)
            .ok_or_else(|| corrupt(format!("{context} has no POSITION attribute")))?;
        let positions = self.read_attribute(&position_accessor, POSITION_LAYOUTS, || {
            reader.read_positions()
        })?;
        let normals = primitive
            .get(&Semantic::Normals)
            .map(|accessor| {
                self.read_attribute(&accessor, NORMAL_LAYOUTS, || reader.read_normals())
            })
            .transpose()?;
        let uvs = primitive
            .get(&Semantic::TexCoords(uv_set))
            .map(|accessor| {
                self.read_attribute(&accessor, TEX_COORD_LAYOUTS, || {
                    reader.read_tex_coords(uv_set).map(|uvs| uvs.into_f32())
                })
            })
            .transpose()?
            .map(|uvs| match uv_transform {
                Some(transform) => uvs.into_iter().map(|uv| transform.apply(uv)).collect(),
                None => uvs,
            });
        let colors = primitive
            .get(&Semantic::Colors(0))
            .map(|accessor| {
                self.read(&accessor, COLOR_LAYOUTS, || {
                    reader.read_colors(0).map(|colors| colors.into_rgba_f32())
                })
            })
            .transpose()?;
        let indices = primitive
            .indices()
            .map(|accessor| {
                self.read(&accessor, INDEX_LAYOUTS, || {
                    reader.read_indices().map(|indices| indices.into_u32())
                })
            })
            .transpose()?;

        let count = positions.len();
        for (name, len) in [
            ("NORMAL".to_string(), normals.as_ref().map(Vec::len)),
            (format!("TEXCOORD_{uv_set}"), uvs.as_ref().map(Vec::len)),
            ("COLOR_0".to_string(), colors.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len.filter(|&len| len != count) {
                return Err(corrupt(format!(
                    "{context}: {name} has {len} elements but POSITION has {count}"
                )));
            }
        }
        if let Some(&index) = indices.iter().flatten().find(|&&i| i as usize >= count) {
            return Err(ErrorKind::IndexOutOfRange {
                context: context.to_string(),
                index: i64::from(index),
                count,
            });
        }
        let corner_count = indices.as_ref().map_or(count, Vec::len);
        self.builder.check_room(count, corner_count, &self.limits)?;
        let base = self.builder.positions.len();
        if base
            .checked_add(count)
            .is_none_or(|total| total > u32::MAX as usize)
        {
            return Err(corrupt("too many vertices for 32-bit indices"));
        }

        for i in 0..count {
            let position = world.transform_point3(Vec3::from(positions[i]));
            let normal = normals.as_ref().map(|n| {
                (normal_matrix * Vec3::from(n[i]))
                    .normalize_or_zero()
                    .to_array()
            });
            self.builder.push_vertex(
                position.to_array(),
                normal,
                uvs.as_ref().map(|uv| uv[i]),
                colors.as_ref().map(|c| c[i]),
            );
        }

        let corner = |k: usize| indices.as_ref().map_or(k as u32, |indices| indices[k]);
        let mode = primitive.mode();
        if mode == Mode::Triangles && corner_count % 3 != 0 {
            self.warn(format!(
                "{context}: {corner_count} corners is not a multiple of 3; the last {} are ignored",
                corner_count % 3
            ));
        }
        let base = base as u32;
        for [a, b, c] in assemble(mode, corner_count, corner) {
            let triangle = if flip { [a, c, b] } else { [a, b, c] };
            self.builder
                .push_triangle(triangle.map(|i| base + i), material);
        }
        Ok(())
    }

    /// Checks an accessor (see [`Loader::check_accessor`]) and reads it with the gltf reader.
    fn read<T, I: Iterator<Item = T>>(
        &self,
        accessor: &Accessor<'_>,
        layouts: &[(DataType, Dimensions)],
        read: impl FnOnce() -> Option<I>,
    ) -> Result<Vec<T>, ErrorKind> {
        self.check_accessor(accessor, layouts)?;
        let values =
            read().ok_or_else(|| corrupt(format!("cannot read accessor {}", accessor.index())))?;
        Ok(values.collect())
    }

    /// Reads a vertex attribute as floats: float elements with the gltf reader (which also
    /// applies sparse substitution), the integer ones of KHR_mesh_quantization here.
    fn read_attribute<const N: usize, I: Iterator<Item = [f32; N]>>(
        &self,
        accessor: &Accessor<'_>,
        layouts: &[(DataType, Dimensions)],
        read: impl FnOnce() -> Option<I>,
    ) -> Result<Vec<[f32; N]>, ErrorKind> {
        if accessor.data_type() == DataType::F32 {
            return self.read(accessor, layouts, read);
        }
        self.read_integers(accessor, layouts)
    }

    /// Reads integer elements as glTF converts them: normalized ones to [0, 1] (unsigned) or
    /// [-1, 1] (signed), the others as they are.
    fn read_integers<const N: usize>(
        &self,
        accessor: &Accessor<'_>,
        layouts: &[(DataType, Dimensions)],
    ) -> Result<Vec<[f32; N]>, ErrorKind> {
        self.check_accessor(accessor, layouts)?;
        let index = accessor.index();
        if accessor.sparse().is_some() {
            return Err(corrupt(format!(
                "accessor {index}: sparse integer vertex attributes are not supported"
            )));
        }
        let count = accessor.count();
        let Some(view) = accessor.view() else {
            return Ok(vec![[0.0; N]; count]);
        };
        let data = view_bytes(self.buffers, &view)?;
        let (data_type, normalized) = (accessor.data_type(), accessor.normalized());
        let component = data_type.size();
        let stride = view.stride().unwrap_or(component * N);
        // check_accessor has checked that every element lies within the view.
        let value = |at: usize| -> f32 {
            let (value, scale) = match data_type {
                DataType::I8 => (f32::from(data[at] as i8), 127.0),
                DataType::U8 => (f32::from(data[at]), 255.0),
                DataType::I16 => (
                    f32::from(i16::from_le_bytes([data[at], data[at + 1]])),
                    32767.0,
                ),
                _ => (
                    f32::from(u16::from_le_bytes([data[at], data[at + 1]])),
                    65535.0,
                ),
            };
            if normalized {
                (value / scale).max(-1.0)
            } else {
                value
            }
        };
        Ok((0..count)
            .map(|i| {
                let at = accessor.offset() + i * stride;
                std::array::from_fn(|c| value(at + c * component))
            })
            .collect())
    }

    /// Checks what the gltf reader assumes without checking: a layout it decodes, at least one
    /// element, strides no smaller than an element, and every byte it reads within its buffer.
    fn check_accessor(
        &self,
        accessor: &Accessor<'_>,
        layouts: &[(DataType, Dimensions)],
    ) -> Result<(), ErrorKind> {
        let index = accessor.index();
        let layout = (accessor.data_type(), accessor.dimensions());
        if !layouts.contains(&layout) {
            return Err(corrupt(format!(
                "accessor {index}: {:?} of {:?} is not a valid layout for its use",
                layout.1, layout.0
            )));
        }
        let count = accessor.count();
        if count == 0 {
            return Err(corrupt(format!("accessor {index} has no elements")));
        }
        let size = accessor.size();
        match accessor.view() {
            Some(view) => self.check_span(&view, accessor.offset(), count, size, index)?,
            None if count > MAX_UNBACKED_ELEMENTS => {
                return Err(corrupt(format!(
                    "accessor {index}: {count} elements without a buffer view is too many"
                )));
            }
            None => {}
        }
        if let Some(sparse) = accessor.sparse() {
            let sparse_count = sparse.count();
            if sparse_count == 0 || sparse_count > count {
                return Err(corrupt(format!(
                    "accessor {index}: sparse count {sparse_count} is not in 1..={count}"
                )));
            }
            let indices = sparse.indices();
            let index_size = indices.index_type().size();
            self.check_span(
                &indices.view(),
                indices.offset(),
                sparse_count,
                index_size,
                index,
            )?;
            let values = sparse.values();
            self.check_span(&values.view(), values.offset(), sparse_count, size, index)?;
        }
        Ok(())
    }

    /// Checks that `count` elements of `size` bytes from `offset` lie within the view, and the
    /// view within its buffer.
    fn check_span(
        &self,
        view: &gltf::buffer::View<'_>,
        offset: usize,
        count: usize,
        size: usize,
        accessor: usize,
    ) -> Result<(), ErrorKind> {
        let stride = view.stride().unwrap_or(size);
        if stride < size {
            return Err(corrupt(format!(
                "accessor {accessor}: buffer view {} has a stride of {stride} bytes, \
                 less than one {size}-byte element",
                view.index()
            )));
        }
        view_bytes(self.buffers, view)?;
        let end = (count - 1)
            .checked_mul(stride)
            .and_then(|n| n.checked_add(size))
            .and_then(|n| n.checked_add(offset));
        if end.is_none_or(|end| end > view.length()) {
            return Err(corrupt(format!(
                "accessor {accessor} reads past the end of buffer view {}",
                view.index()
            )));
        }
        Ok(())
    }

    /// The canonical material for a primitive's material, and the texture coordinates its
    /// base-colour texture samples (which become the canonical UVs of the primitive).
    fn material(&mut self, material: gltf::Material<'_>) -> Result<MaterialUse, ErrorKind> {
        let Some(index) = material.index() else {
            let slot = match self.default_material {
                Some(slot) => slot,
                None => {
                    let slot = self.builder.add_material(Material::default());
                    *self.default_material.insert(slot)
                }
            };
            return Ok(MaterialUse {
                slot,
                uv_set: 0,
                uv_transform: None,
            });
        };
        if let Some(Some(known)) = self.materials.get(index) {
            return Ok(*known);
        }
        let name = material
            .name()
            .map_or_else(|| format!("material {index}"), str::to_string);
        let raw = self.raw;
        let extension = |path: &str| raw.pointer(&format!("/materials/{index}/{path}")).is_some();
        if extension("extensions/KHR_materials_pbrSpecularGlossiness") {
            self.warn(format!(
                "material `{name}` uses KHR_materials_pbrSpecularGlossiness, which is ignored \
                 (its metallic-roughness base colour is used)"
            ));
        }
        // The relief maps carry the base colour (alpha-tested where MASK): what else makes the
        // surface look as it does is said, so nobody takes the impostor's look for a bug.
        if material.alpha_mode() == gltf::material::AlphaMode::Blend {
            self.warn(format!(
                "material `{name}` is alpha-blended (alphaMode BLEND); the ORI draws it opaque"
            ));
        }
        if material.emissive_factor() != [0.0; 3] || material.emissive_texture().is_some() {
            self.warn(format!(
                "material `{name}`: its emission is ignored (the ORI carries the base colour only)"
            ));
        }
        let extensions = raw
            .pointer(&format!("/materials/{index}/extensions"))
            .and_then(Value::as_object);
        let ignored = extensions
            .into_iter()
            .flat_map(|e| e.keys())
            .filter(|e| *e != "KHR_materials_pbrSpecularGlossiness");
        for extension in ignored.cloned().collect::<Vec<_>>() {
            self.warn(format!(
                "material `{name}`: {extension} is ignored (the ORI carries the base colour only)"
            ));
        }
        let pbr = material.pbr_metallic_roughness();
        let (texture, uv_set, uv_transform) = match pbr.base_color_texture() {
            Some(info) => {
                let pointer = format!(
                    "/materials/{index}/pbrMetallicRoughness/baseColorTexture/extensions/KHR_texture_transform"
                );
                let (uv_transform, uv_set) = match raw.pointer(&pointer) {
                    Some(json) => {
                        let (transform, set) = UvTransform::parse(json).map_err(|e| {
                            corrupt(format!("material `{name}`: KHR_texture_transform: {e}"))
                        })?;
                        (Some(transform), set.unwrap_or(info.tex_coord()))
                    }
                    None => (None, info.tex_coord()),
                };
                let texture = match self.texture(&info.texture()) {
                    Ok(texture) => Some(texture),
                    Err(ErrorKind::UnsupportedImage {
                        name: image,
                        format,
                    }) => {
                        self.warn(format!(
                            "material `{name}`: its base-colour image `{image}` is {format}, which \
                             the ORI cannot read (only PNG and JPEG); drawn with its base colour \
                             factor alone"
                        ));
                        None
                    }
                    Err(e) => return Err(e),
                };
                (texture, uv_set, uv_transform)
            }
            None => (None, 0, None),
        };
        let converted = Material {
            name,
            base_color_factor: pbr.base_color_factor(),
            base_color_texture: texture,
            alpha_mode: match material.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask,
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            },
            alpha_cutoff: material.alpha_cutoff().unwrap_or(DEFAULT_ALPHA_CUTOFF),
            double_sided: material.double_sided(),
        };
        let known = MaterialUse {
            slot: self.builder.add_material(converted),
            uv_set,
            uv_transform,
        };
        if let Some(slot) = self.materials.get_mut(index) {
            *slot = Some(known);
        }
        Ok(known)
    }

    /// The canonical texture for a glTF texture: its image (decoded once) with its sampler.
    fn texture(&mut self, texture: &gltf::Texture<'_>) -> Result<u32, ErrorKind> {
        let image = texture.source().index();
        let sampler = texture.sampler();
        let key = (image, sampler.index());
        if let Some(&known) = self.textures.get(&key) {
            return Ok(known);
        }
        let decoded = self
            .decoded_images
            .get(&image)
            .and_then(|&known| self.builder.textures.get(known as usize).cloned());
        let pixels = match decoded {
            Some(pixels) => pixels,
            None => self.decode_image(image)?,
        };
        let wrap = |mode| match mode {
            WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
            WrappingMode::Repeat => Wrap::Repeat,
        };
        let index = self.builder.textures.len() as u32;
        self.builder.textures.push(Texture {
            wrap_s: wrap(sampler.wrap_s()),
            wrap_t: wrap(sampler.wrap_t()),
            nearest: sampler.mag_filter() == Some(MagFilter::Nearest),
            ..pixels
        });
        self.decoded_images.entry(image).or_insert(index);
        self.textures.insert(key, index);
        Ok(index)
    }

    /// Reads and decodes one image. Its JSON is read directly because `gltf::Image::source`
    /// panics on a buffer-view image without a MIME type and on one with neither source.
    fn decode_image(&mut self, image: usize) -> Result<Texture, ErrorKind> {
        let json = self
            .document
            .as_json()
            .images
            .get(image)
            .ok_or_else(|| corrupt(format!("image {image} does not exist")))?;
        let fallback_name = || {
            json.name
                .clone()
                .unwrap_or_else(|| format!("image {image}"))
        };
        let (name, bytes) = match (&json.buffer_view, &json.uri) {
            (Some(view), _) => {
                let view = self
                    .document
                    .views()
                    .nth(view.value())
                    .ok_or_else(|| corrupt(format!("image {image}: no such buffer view")))?;
                (
                    fallback_name(),
                    Cow::Borrowed(view_bytes(self.buffers, &view)?),
                )
            }
            (None, Some(uri)) => {
                let name = if uri.starts_with("data:") {
                    fallback_name()
                } else {
                    uri.clone()
                };
                (name, Cow::Owned(read_uri(uri, self.resolver)?))
            }
            (None, None) => {
                return Err(corrupt(format!(
                    "image {image} has neither a uri nor a bufferView"
                )));
            }
        };
        texture::decode(&name, &bytes, &mut self.budget)
    }
}

/// The bytes of a buffer view, checked to lie within its buffer.
fn view_bytes<'a>(
    buffers: &'a [Cow<'a, [u8]>],
    view: &gltf::buffer::View<'_>,
) -> Result<&'a [u8], ErrorKind> {
    let buffer = view.buffer().index();
    view.offset()
        .checked_add(view.length())
        .and_then(|end| buffers.get(buffer)?.get(view.offset()..end))
        .ok_or_else(|| {
            corrupt(format!(
                "buffer view {} extends past the end of buffer {buffer}",
                view.index()
            ))
        })
}

/// Triangles (as corner numbers of the primitive's vertex or index list, whose `k`-th vertex is
/// `corner(k)`) in the winding the glTF specification gives each mode.
fn assemble(mode: Mode, corners: usize, corner: impl Fn(usize) -> u32) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => (0..corners / 3)
            .map(|t| [corner(3 * t), corner(3 * t + 1), corner(3 * t + 2)])
            .collect(),
        // Odd triangles swap their last two corners so that all keep the first one's winding.
        Mode::TriangleStrip => (0..corners.saturating_sub(2))
            .map(|i| {
                let (b, c) = if i % 2 == 0 {
                    (i + 1, i + 2)
                } else {
                    (i + 2, i + 1)
                };
                [corner(i), corner(b), corner(c)]
            })
            .collect(),
        Mode::TriangleFan => (1..corners.saturating_sub(1))
            .map(|i| [corner(0), corner(i), corner(i + 1)])
            .collect(),
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_transforms_scale_then_rotate_then_offset() {
        let json: Value = gltf::json::deserialize::from_str(
            r#"{"offset": [0.5, 0.25], "rotation": 1.5707964, "scale": [2, 3], "texCoord": 1}"#,
        )
        .unwrap();
        let (transform, set) = UvTransform::parse(&json).unwrap();
        assert_eq!(set, Some(1));
        // (1, 0) scaled to (2, 0), turned a quarter towards -v: (0, -2), then offset.
        let [u, v] = transform.apply([1.0, 0.0]);
        assert!(
            (u - 0.5).abs() < 1e-6 && (v - -1.75).abs() < 1e-6,
            "{u} {v}"
        );
        // (0, 1) scaled to (0, 3), turned to (3, 0).
        let [u, v] = transform.apply([0.0, 1.0]);
        assert!((u - 3.5).abs() < 1e-6 && (v - 0.25).abs() < 1e-6, "{u} {v}");
        for bad in [
            r#"{"scale": [1]}"#,
            r#"{"rotation": "x"}"#,
            r#"{"texCoord": -1}"#,
        ] {
            let json: Value = gltf::json::deserialize::from_str(bad).unwrap();
            assert!(UvTransform::parse(&json).is_err(), "{bad}");
        }
    }
}
