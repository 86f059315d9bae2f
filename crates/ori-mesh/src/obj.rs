//! Wavefront OBJ with MTL materials.
//!
//! One pass over the lines collects positions, texture coordinates, normals and face corners;
//! vertices are built afterwards, so faces may refer to `v` lines further down and `usemtl` may
//! name a material from any `mtllib`. When no face corner has a texture coordinate or normal,
//! every `v` becomes a vertex in file order (vertex numbers then match the file and what other
//! tools report); otherwise each distinct (position, uv, normal) corner becomes one vertex, in
//! order of first use.
//!
//! Conventions: `v` colours and `Kd` are display (sRGB) values and are made linear; `vt`'s v is
//! flipped to glTF's downward v. Materials are always [`AlphaMode::Opaque`]: `d`/`Tr` only set
//! the factor's alpha, because MTL cannot say whether transparency means a cut-out or a blend.

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::builder::MeshBuilder;
use crate::texture::TextureBudget;
use crate::{AlphaMode, ErrorKind, Limits, Material, MeshError, Resolver, texture};

/// Marks a face corner without a texture coordinate or normal.
const NONE: u32 = u32::MAX;

pub(crate) fn load(
    path: &Path,
    bytes: &[u8],
    limits: &Limits,
    resolver: &mut Resolver<'_>,
    warnings: &mut Vec<String>,
) -> Result<MeshBuilder, MeshError> {
    let mut obj = Obj {
        limits: *limits,
        ..Obj::default()
    };
    let mut library = Library::new(path, limits);
    let mut skipped_elements = 0usize;
    let mut unsupported: Vec<String> = Vec::new();
    for (line, text) in Lines::new(bytes) {
        let mut args = words(&text);
        let Some(keyword) = args.next() else {
            continue;
        };
        let parsed = match keyword {
            b"v" => obj.position(args, line),
            b"vt" => obj.uv(args, line),
            b"vn" => obj.normal(args, line),
            b"f" => obj.face(args, line),
            b"usemtl" => obj.use_material(rest_of_line(&text), line),
            b"mtllib" => {
                for name in args {
                    library.load(name, resolver, warnings)?;
                }
                Ok(())
            }
            b"o" | b"g" | b"s" => Ok(()),
            b"l" | b"p" => {
                skipped_elements += 1;
                Ok(())
            }
            _ if keyword.starts_with(b"#") => Ok(()),
            _ => {
                let name = String::from_utf8_lossy(keyword).into_owned();
                if !unsupported.contains(&name) {
                    unsupported.push(name);
                }
                Ok(())
            }
        };
        parsed.map_err(|kind| kind.in_file(path))?;
    }
    if skipped_elements > 0 {
        warnings.push(format!(
            "skipped {skipped_elements} line/point elements (`l`, `p`): only faces are loaded"
        ));
    }
    if !unsupported.is_empty() {
        warnings.push(format!(
            "ignored unsupported OBJ statements: {}",
            unsupported.join(", ")
        ));
    }
    obj.build(path, &mut library, resolver, warnings)
}

/// Everything read from the OBJ file, before vertices are built.
struct Obj {
    positions: Vec<[f32; 3]>,
    /// Linear RGBA per position (white where a `v` line has no colour).
    colors: Vec<[f32; 4]>,
    any_color: bool,
    uvs: Vec<[f32; 2]>,
    normals: Vec<[f32; 3]>,
    /// Zero-based (position, uv, normal) of every face corner; positive indices are checked
    /// against the final counts in [`Obj::build`], since files may refer forwards.
    corners: Vec<[u32; 3]>,
    /// Whether any corner has a uv or normal, which decides how vertices are built.
    any_corner_attribute: bool,
    faces: Vec<Face>,
    /// Material names in order of `usemtl`; slot 0 is "no usemtl yet".
    slots: Vec<Slot>,
    slot_of: HashMap<String, usize>,
    current_slot: usize,
    limits: Limits,
}

impl Default for Obj {
    fn default() -> Self {
        Obj {
            positions: Vec::new(),
            colors: Vec::new(),
            any_color: false,
            uvs: Vec::new(),
            normals: Vec::new(),
            corners: Vec::new(),
            any_corner_attribute: false,
            faces: Vec::new(),
            slots: vec![Slot {
                name: None,
                line: 0,
            }],
            slot_of: HashMap::new(),
            current_slot: 0,
            limits: Limits::default(),
        }
    }
}

/// A polygon: `count` corners from `first` in [`Obj::corners`].
struct Face {
    first: usize,
    count: usize,
    line: usize,
    slot: usize,
}

/// A material name from `usemtl` and the line it first appeared on (for warnings).
struct Slot {
    name: Option<String>,
    line: usize,
}

impl Obj {
    /// `v x y z [w]` or `v x y z r g b`; `w` only matters for rational curves, so it is ignored.
    fn position<'a>(
        &mut self,
        args: impl Iterator<Item = &'a [u8]>,
        line: usize,
    ) -> Result<(), ErrorKind> {
        let mut values = [0.0f32; 6];
        let n = read_floats(args, &mut values, line, "v")?;
        let color = match n {
            3 | 4 => None,
            6 => {
                let rgb = finite(&values[3..6], line, "v")?;
                Some(srgb_color(rgb))
            }
            _ => {
                return Err(syntax(
                    line,
                    format!("`v` needs x y z, optionally followed by r g b; found {n} values"),
                ));
            }
        };
        self.positions.push([values[0], values[1], values[2]]);
        self.any_color |= color.is_some();
        self.colors.push(color.unwrap_or([1.0; 4]));
        Ok(())
    }

    /// `vt u [v [w]]`, flipped to glTF's v.
    fn uv<'a>(
        &mut self,
        args: impl Iterator<Item = &'a [u8]>,
        line: usize,
    ) -> Result<(), ErrorKind> {
        let mut values = [0.0f32; 3];
        let n = read_floats(args, &mut values, line, "vt")?;
        if n == 0 {
            return Err(syntax(line, "`vt` needs at least u".into()));
        }
        let [u, v] = finite(&values[..2], line, "vt")?;
        self.uvs.push([u, 1.0 - v]);
        Ok(())
    }

    /// `vn x y z` (not necessarily unit length; the builder normalises).
    fn normal<'a>(
        &mut self,
        args: impl Iterator<Item = &'a [u8]>,
        line: usize,
    ) -> Result<(), ErrorKind> {
        let mut values = [0.0f32; 3];
        let n = read_floats(args, &mut values, line, "vn")?;
        if n != 3 {
            return Err(syntax(line, format!("`vn` needs x y z; found {n} values")));
        }
        self.normals.push(values);
        Ok(())
    }

    /// `f` with corners `i`, `i/t`, `i//n` or `i/t/n`.
    fn face<'a>(
        &mut self,
        args: impl Iterator<Item = &'a [u8]>,
        line: usize,
    ) -> Result<(), ErrorKind> {
        let first = self.corners.len();
        for word in args {
            if self.corners.len() - first == self.limits.max_face_corners {
                self.corners.truncate(first);
                return Err(syntax(
                    line,
                    format!(
                        "a face has more than {} corners, the limit ([limits] max_face_corners)",
                        self.limits.max_face_corners
                    ),
                ));
            }
            match self.corner(word, line) {
                Ok(corner) => self.corners.push(corner),
                Err(e) => {
                    self.corners.truncate(first);
                    return Err(e);
                }
            }
        }
        let count = self.corners.len() - first;
        if count < 3 {
            self.corners.truncate(first);
            return Err(syntax(
                line,
                format!("a face needs at least 3 corners; found {count}"),
            ));
        }
        self.faces.push(Face {
            first,
            count,
            line,
            slot: self.current_slot,
        });
        Ok(())
    }

    fn corner(&mut self, word: &[u8], line: usize) -> Result<[u32; 3], ErrorKind> {
        let malformed = || {
            syntax(
                line,
                format!("malformed face corner `{}`", String::from_utf8_lossy(word)),
            )
        };
        let mut parts = word.split(|&b| b == b'/');
        let position = parts.next().ok_or_else(malformed)?;
        let uv = parts.next().filter(|p| !p.is_empty());
        let normal = parts.next().filter(|p| !p.is_empty());
        if parts.next().is_some() {
            return Err(malformed());
        }
        let index = |part: &[u8], count: usize, what: &str| {
            let i = parse_index(part).ok_or_else(malformed)?;
            resolve(i, count, line, what)
        };
        let position = index(position, self.positions.len(), "face")?;
        let uv = match uv {
            Some(part) => index(part, self.uvs.len(), "face texture coordinate")?,
            None => NONE,
        };
        let normal = match normal {
            Some(part) => index(part, self.normals.len(), "face normal")?,
            None => NONE,
        };
        self.any_corner_attribute |= uv != NONE || normal != NONE;
        Ok([position, uv, normal])
    }

    fn use_material(&mut self, name: &[u8], line: usize) -> Result<(), ErrorKind> {
        if name.is_empty() {
            return Err(syntax(line, "`usemtl` needs a material name".into()));
        }
        let name = String::from_utf8_lossy(name);
        self.current_slot = match self.slot_of.get(&*name) {
            Some(&slot) => slot,
            None => {
                let slot = self.slots.len();
                self.slots.push(Slot {
                    name: Some(name.to_string()),
                    line,
                });
                self.slot_of.insert(name.into_owned(), slot);
                slot
            }
        };
        Ok(())
    }

    /// Check every corner, build vertices and fan-triangulate, adding materials (and their
    /// textures) in order of first use.
    fn build(
        self,
        path: &Path,
        library: &mut Library,
        resolver: &mut Resolver<'_>,
        warnings: &mut Vec<String>,
    ) -> Result<MeshBuilder, MeshError> {
        let mut builder = MeshBuilder::default();
        let positions_only = !self.any_corner_attribute;
        let color = |p: usize| self.any_color.then(|| self.colors[p]);
        if positions_only {
            builder
                .check_room(self.positions.len(), 0, &self.limits)
                .map_err(|k| k.in_file(path))?;
            for (p, &position) in self.positions.iter().enumerate() {
                builder.push_vertex(position, None, None, color(p));
            }
        }
        let mut vertex_of: HashMap<[u32; 3], u32> = HashMap::new();
        let mut slot_material: Vec<Option<u32>> = vec![None; self.slots.len()];
        let mut default_material = None;
        let mut face_vertices = Vec::new();
        for face in &self.faces {
            let material = match slot_material[face.slot] {
                Some(m) => m,
                None => {
                    let slot = &self.slots[face.slot];
                    let m = library.material(
                        slot,
                        &mut default_material,
                        &mut builder,
                        resolver,
                        warnings,
                    )?;
                    slot_material[face.slot] = Some(m);
                    m
                }
            };
            builder
                .check_room(face.count, face.count - 2, &self.limits)
                .map_err(|k| k.in_file(path))?;
            face_vertices.clear();
            for &corner in &self.corners[face.first..face.first + face.count] {
                let [p, t, n] = corner;
                let check = |index: u32, count: usize, what: &str| {
                    if index == NONE || (index as usize) < count {
                        Ok(())
                    } else {
                        Err(ErrorKind::IndexOutOfRange {
                            context: format!("line {}: {what}", face.line),
                            index: i64::from(index) + 1,
                            count,
                        }
                        .in_file(path))
                    }
                };
                check(p, self.positions.len(), "face")?;
                let vertex = if positions_only {
                    p
                } else {
                    check(t, self.uvs.len(), "face texture coordinate")?;
                    check(n, self.normals.len(), "face normal")?;
                    match vertex_of.get(&corner) {
                        Some(&v) => v,
                        None => {
                            let v = builder.push_vertex(
                                self.positions[p as usize],
                                (n != NONE).then(|| self.normals[n as usize]),
                                (t != NONE).then(|| self.uvs[t as usize]),
                                color(p as usize),
                            );
                            vertex_of.insert(corner, v);
                            v
                        }
                    }
                };
                face_vertices.push(vertex);
            }
            let first = face_vertices[0];
            for pair in face_vertices[1..].windows(2) {
                builder.push_triangle([first, pair[0], pair[1]], material);
            }
        }
        Ok(builder)
    }
}

/// Material definitions from every `mtllib`, and the textures loaded for them so far.
struct Library {
    /// The model's folder; MTL paths in errors are relative to it.
    dir: PathBuf,
    model: PathBuf,
    /// References already read, so a library named twice is read once.
    loaded: Vec<String>,
    /// Path of each MTL file, for errors about its materials.
    files: Vec<PathBuf>,
    definitions: HashMap<String, Definition>,
    /// Texture index by resolver reference.
    textures: HashMap<String, u32>,
    budget: TextureBudget,
}

/// One `newmtl` block, as written.
struct Definition {
    /// Index into [`Library::files`].
    file: usize,
    diffuse: [f32; 3],
    dissolve: Option<f32>,
    transparency: Option<f32>,
    /// Resolver reference of `map_Kd`.
    texture: Option<String>,
}

impl Library {
    fn new(model: &Path, limits: &Limits) -> Library {
        Library {
            budget: TextureBudget::new(limits),
            dir: model.parent().unwrap_or(Path::new("")).to_path_buf(),
            model: model.to_path_buf(),
            loaded: Vec::new(),
            files: Vec::new(),
            definitions: HashMap::new(),
            textures: HashMap::new(),
        }
    }

    /// Read and parse one `mtllib` file. A missing library is an error on the model, because
    /// that is where the broken reference is written.
    fn load(
        &mut self,
        name: &[u8],
        resolver: &mut Resolver<'_>,
        warnings: &mut Vec<String>,
    ) -> Result<(), MeshError> {
        let reference = String::from_utf8_lossy(name).replace('\\', "/");
        if self.loaded.contains(&reference) {
            return Ok(());
        }
        let bytes = resolver.read(&reference).map_err(|source| {
            ErrorKind::MissingExternal {
                uri: reference.clone(),
                source,
            }
            .in_file(&self.model)
        })?;
        let file = self.dir.join(&reference);
        let index = self.files.len();
        let mut textures = parse_mtl(&bytes, &reference, index, &mut self.definitions, warnings)
            .map_err(|kind| kind.in_file(&file))?;
        textures.sort_unstable();
        textures.dedup();
        if !textures.is_empty() {
            resolver.will_read(&textures);
        }
        self.files.push(file);
        self.loaded.push(reference);
        Ok(())
    }

    /// The builder material for a `usemtl` slot; unknown names fall back to the default.
    fn material(
        &mut self,
        slot: &Slot,
        default_material: &mut Option<u32>,
        builder: &mut MeshBuilder,
        resolver: &mut Resolver<'_>,
        warnings: &mut Vec<String>,
    ) -> Result<u32, MeshError> {
        let definition = slot.name.as_ref().and_then(|name| {
            let found = self.definitions.get(name);
            if found.is_none() {
                warnings.push(format!(
                    "line {}: material `{name}` is not defined in any mtllib; using the default material",
                    slot.line
                ));
            }
            found.map(|d| (name, d))
        });
        let Some((name, definition)) = definition else {
            return Ok(
                *default_material.get_or_insert_with(|| builder.add_material(Material::default()))
            );
        };
        let alpha = definition
            .dissolve
            .or(definition.transparency.map(|t| 1.0 - t))
            .unwrap_or(1.0)
            .clamp(0.0, 1.0);
        let [r, g, b, _] = srgb_color(definition.diffuse);
        let mut material = Material {
            name: name.clone(),
            base_color_factor: [r, g, b, alpha],
            alpha_mode: AlphaMode::Opaque,
            ..Material::default()
        };
        // Cloned out of the definition, because loading the texture updates the texture cache.
        if let Some(reference) = definition.texture.clone() {
            let file = definition.file;
            material.base_color_texture = match self.texture(&reference, file, builder, resolver) {
                Ok(texture) => Some(texture),
                Err(MeshError {
                    kind: ErrorKind::UnsupportedImage { format, .. },
                    ..
                }) => {
                    warnings.push(format!(
                        "material `{name}`: its texture `{reference}` is {format}, which the ORI \
                         cannot read (only PNG and JPEG); drawn with its colour alone"
                    ));
                    None
                }
                Err(e) => return Err(e),
            };
        }
        Ok(builder.add_material(material))
    }

    /// Decode a texture once per reference; errors are reported on the MTL that names it.
    fn texture(
        &mut self,
        reference: &str,
        file: usize,
        builder: &mut MeshBuilder,
        resolver: &mut Resolver<'_>,
    ) -> Result<u32, MeshError> {
        if let Some(&index) = self.textures.get(reference) {
            return Ok(index);
        }
        let mtl = &self.files[file];
        let bytes = resolver.read(reference).map_err(|source| {
            ErrorKind::MissingExternal {
                uri: reference.to_string(),
                source,
            }
            .in_file(mtl)
        })?;
        let texture = texture::decode(reference, &bytes, &mut self.budget)
            .map_err(|kind| kind.in_file(mtl))?;
        builder.textures.push(texture);
        let index = (builder.textures.len() - 1) as u32;
        self.textures.insert(reference.to_string(), index);
        Ok(index)
    }
}

/// Parse an MTL file into `definitions` (a later `newmtl` of the same name wins); the textures
/// its `map_Kd` statements name, as the resolver is asked for them.
fn parse_mtl(
    bytes: &[u8],
    reference: &str,
    file: usize,
    definitions: &mut HashMap<String, Definition>,
    warnings: &mut Vec<String>,
) -> Result<Vec<String>, ErrorKind> {
    let mut current: Option<(String, Definition)> = None;
    let mut textures = Vec::new();
    for (line, text) in Lines::new(bytes) {
        let mut args = words(&text);
        let Some(keyword) = args.next() else {
            continue;
        };
        let keyword = keyword.to_ascii_lowercase();
        if keyword == b"newmtl" {
            let name = rest_of_line(&text);
            if name.is_empty() {
                return Err(syntax(line, "`newmtl` needs a material name".into()));
            }
            if let Some((name, definition)) = current.take() {
                definitions.insert(name, definition);
            }
            let definition = Definition {
                file,
                diffuse: [1.0; 3],
                dissolve: None,
                transparency: None,
                texture: None,
            };
            current = Some((String::from_utf8_lossy(name).into_owned(), definition));
            continue;
        }
        // Statements before the first `newmtl` have no material to apply to.
        let Some((name, definition)) = current.as_mut() else {
            continue;
        };
        match keyword.as_slice() {
            b"kd" => {
                let mut values = [0.0f32; 3];
                let mut args = args.peekable();
                if args
                    .peek()
                    .is_some_and(|w| *w == b"spectral" || *w == b"xyz")
                {
                    warnings.push(format!(
                        "{reference}: material `{name}`: only RGB `Kd` is supported; using white"
                    ));
                    continue;
                }
                definition.diffuse = match read_floats(args, &mut values, line, "Kd")? {
                    1 => finite(&[values[0]; 3], line, "Kd")?,
                    3 => finite(&values, line, "Kd")?,
                    n => {
                        return Err(syntax(line, format!("`Kd` needs r g b; found {n} values")));
                    }
                };
            }
            // `d [-halo] factor`: the factor is the last word.
            b"d" => definition.dissolve = Some(last_float(args, line, "d")?),
            b"tr" => definition.transparency = Some(last_float(args, line, "Tr")?),
            b"map_kd" => {
                let file_name = map_file(rest_of_line(&text))
                    .ok_or_else(|| syntax(line, "`map_Kd` needs an image file name".into()))?;
                let texture = texture_reference(reference, file_name);
                textures.push(texture.clone());
                definition.texture = Some(texture);
            }
            b"map_d" => warnings.push(format!(
                "{reference}: material `{name}`: `map_d` alpha textures are not supported; ignored"
            )),
            _ => {}
        }
    }
    if let Some((name, definition)) = current {
        definitions.insert(name, definition);
    }
    Ok(textures)
}

/// The image file of a `map_*` statement. Options (`-s 1 1 1`, `-clamp on`, ...) come first;
/// the rest of the line is the name, which may contain spaces. After an option this parser
/// does not know, the last word is taken as the name.
fn map_file(args: &[u8]) -> Option<&[u8]> {
    let mut rest = args.trim_ascii();
    while rest.starts_with(b"-") {
        let (option, after) = split_word(rest);
        // (required values, optional extra numbers)
        let (required, optional) = match option {
            b"-o" | b"-s" | b"-t" => (1, 2),
            b"-mm" => (2, 0),
            b"-blendu" | b"-blendv" | b"-bm" | b"-boost" | b"-cc" | b"-clamp" | b"-imfchan"
            | b"-texres" | b"-type" => (1, 0),
            _ => return rest.rsplit(u8::is_ascii_whitespace).find(|w| !w.is_empty()),
        };
        rest = after;
        for i in 0..required + optional {
            let (value, after) = split_word(rest);
            if value.is_empty() || (i >= required && parse_f32(value).is_none()) {
                break;
            }
            rest = after;
        }
    }
    (!rest.is_empty()).then_some(rest)
}

/// A `map_Kd` name as a resolver reference: relative to the MTL's folder, `/`-separated.
fn texture_reference(mtl_reference: &str, name: &[u8]) -> String {
    let name = String::from_utf8_lossy(name).replace('\\', "/");
    match mtl_reference.rfind('/') {
        Some(end) if !name.starts_with('/') => format!("{}/{name}", &mtl_reference[..end]),
        _ => name,
    }
}

/// Lines with their 1-based numbers; a trailing `\` joins the next line (numbered as the first).
struct Lines<'a> {
    rest: &'a [u8],
    number: usize,
}

impl<'a> Lines<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        let rest = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        Lines { rest, number: 0 }
    }

    fn take_line(&mut self) -> &'a [u8] {
        let (line, rest) = match self.rest.iter().position(|&b| b == b'\n') {
            Some(end) => (&self.rest[..end], &self.rest[end + 1..]),
            None => (self.rest, &[][..]),
        };
        self.rest = rest;
        self.number += 1;
        line
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (usize, Cow<'a, [u8]>);

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let mut line = Cow::Borrowed(self.take_line());
        let number = self.number;
        while let Some(body) = line.trim_ascii_end().strip_suffix(b"\\") {
            let body = body.len();
            let line = line.to_mut();
            line.truncate(body);
            if self.rest.is_empty() {
                break;
            }
            line.push(b' ');
            line.extend_from_slice(self.take_line());
        }
        Some((number, line))
    }
}

/// The words of a line, up to a `#` comment.
fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(u8::is_ascii_whitespace)
        .filter(|w| !w.is_empty())
        .take_while(|w| w[0] != b'#')
}

/// Everything after the keyword, trimmed (names may contain spaces).
fn rest_of_line(line: &[u8]) -> &[u8] {
    split_word(line.trim_ascii_start()).1.trim_ascii()
}

/// The first word and what follows it (leading whitespace of the remainder removed).
fn split_word(text: &[u8]) -> (&[u8], &[u8]) {
    let end = text
        .iter()
        .position(u8::is_ascii_whitespace)
        .unwrap_or(text.len());
    (&text[..end], text[end..].trim_ascii_start())
}

fn syntax(line: usize, message: String) -> ErrorKind {
    ErrorKind::Syntax { line, message }
}

fn parse_f32(word: &[u8]) -> Option<f32> {
    std::str::from_utf8(word).ok()?.parse().ok()
}

/// Parse up to `out.len()` numbers, returning how many there were.
fn read_floats<'a>(
    args: impl Iterator<Item = &'a [u8]>,
    out: &mut [f32],
    line: usize,
    keyword: &str,
) -> Result<usize, ErrorKind> {
    let max = out.len();
    let mut n = 0;
    for word in args {
        let value = parse_f32(word).ok_or_else(|| {
            syntax(
                line,
                format!(
                    "`{keyword}`: malformed number `{}`",
                    String::from_utf8_lossy(word)
                ),
            )
        })?;
        let slot = out
            .get_mut(n)
            .ok_or_else(|| syntax(line, format!("`{keyword}` has more than {max} values")))?;
        *slot = value;
        n += 1;
    }
    Ok(n)
}

fn last_float<'a>(
    args: impl Iterator<Item = &'a [u8]>,
    line: usize,
    keyword: &str,
) -> Result<f32, ErrorKind> {
    let word = args
        .last()
        .ok_or_else(|| syntax(line, format!("`{keyword}` needs a value")))?;
    let value = parse_f32(word).ok_or_else(|| {
        syntax(
            line,
            format!(
                "`{keyword}`: malformed number `{}`",
                String::from_utf8_lossy(word)
            ),
        )
    })?;
    let [value] = finite(&[value], line, keyword)?;
    Ok(value)
}

/// Colours, texture coordinates and factors must be finite (positions are checked later).
fn finite<const N: usize>(
    values: &[f32],
    line: usize,
    keyword: &str,
) -> Result<[f32; N], ErrorKind> {
    let mut out = [0.0; N];
    out.copy_from_slice(&values[..N]);
    if out.iter().all(|v| v.is_finite()) {
        Ok(out)
    } else {
        Err(syntax(line, format!("`{keyword}`: value is not finite")))
    }
}

/// Display RGB to linear RGBA with alpha 1.
fn srgb_color(rgb: [f32; 3]) -> [f32; 4] {
    let [r, g, b] = rgb.map(|c| ori_math::srgb_to_linear(f64::from(c)) as f32);
    [r, g, b, 1.0]
}

/// A decimal index with optional sign, or `None` if malformed or beyond `i64`.
fn parse_index(word: &[u8]) -> Option<i64> {
    let (negative, digits) = match word {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        _ => (false, word),
    };
    if digits.is_empty() {
        return None;
    }
    let mut value: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        value = value.checked_mul(10)?.checked_add(i64::from(d - b'0'))?;
    }
    Some(if negative { -value } else { value })
}

/// A 1-based or negative (relative to the `count` entries read so far) index, zero-based.
/// Positive indices are only checked for size here; [`Obj::build`] checks them against the
/// final count.
fn resolve(index: i64, count: usize, line: usize, what: &str) -> Result<u32, ErrorKind> {
    let out_of_range = |context: String| ErrorKind::IndexOutOfRange {
        context,
        index,
        count,
    };
    let resolved = match index {
        0 => {
            return Err(out_of_range(format!(
                "line {line}: {what} (OBJ indices start at 1)"
            )));
        }
        i if i > 0 => u32::try_from(i - 1).ok(),
        i => usize::try_from(i.unsigned_abs())
            .ok()
            .and_then(|back| count.checked_sub(back))
            .and_then(|r| u32::try_from(r).ok()),
    };
    resolved
        .filter(|&r| r != NONE)
        .ok_or_else(|| out_of_range(format!("line {line}: {what}")))
}
