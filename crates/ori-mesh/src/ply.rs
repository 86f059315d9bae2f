//! Stanford PLY, ASCII and binary in both byte orders.
//!
//! The header is parsed into element layouts, then each element is read in file order by one
//! generic loop over a value reader (binary or ASCII), so both encodings share all checks.
//! Every count from the header is bounded by the bytes left before anything is reserved, and
//! every read is bounds-checked, so truncated or hostile files give errors, not panics.
//!
//! `vertex` gives positions and optional normals, colours (display sRGB, made linear; alpha
//! stays linear) and texture coordinates (v flipped to glTF's convention); `face` gives
//! polygons, fan-triangulated. Other elements and properties are skipped.

use crate::builder::MeshBuilder;
use crate::{ErrorKind, Limits};

pub(crate) fn load(
    bytes: &[u8],
    limits: &Limits,
    warnings: &mut Vec<String>,
) -> Result<MeshBuilder, ErrorKind> {
    let header = Header::parse(bytes)?;
    let body = &bytes[header.body_start..];
    match header.format {
        Encoding::Ascii => read_body(
            &header,
            Ascii::new(body, header.body_line),
            limits,
            warnings,
        ),
        Encoding::BinaryLittleEndian => {
            read_body(&header, Binary::new(body, false), limits, warnings)
        }
        Encoding::BinaryBigEndian => read_body(&header, Binary::new(body, true), limits, warnings),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

/// A PLY scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &[u8]) -> Option<Scalar> {
        Some(match name {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The value meaning "full intensity" for a colour channel of this type.
    fn color_scale(self) -> f64 {
        match self {
            Scalar::I8 | Scalar::U8 => 1.0 / 255.0,
            Scalar::I16 | Scalar::U16 => 1.0 / 65_535.0,
            Scalar::I32 | Scalar::U32 => 1.0 / 4_294_967_295.0,
            Scalar::F32 | Scalar::F64 => 1.0,
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

impl Element {
    /// The fewest bytes one record can take (lists empty), to bound `count` by the data size.
    fn min_record_size(&self, encoding: Encoding) -> usize {
        self.properties
            .iter()
            .map(|p| match (encoding, p.kind) {
                // A number and a separator.
                (Encoding::Ascii, _) => 2,
                (_, Kind::Scalar(ty)) => ty.size(),
                (_, Kind::List { count, .. }) => count.size(),
            })
            .sum()
    }
}

struct Header {
    format: Encoding,
    elements: Vec<Element>,
    body_start: usize,
    /// Line number of the first body line (for ASCII messages).
    body_line: usize,
}

impl Header {
    fn parse(bytes: &[u8]) -> Result<Header, ErrorKind> {
        let mut format = None;
        let mut elements: Vec<Element> = Vec::new();
        let mut pos = 0;
        let mut line = 0;
        loop {
            let Some(end) = bytes[pos..].iter().position(|&b| b == b'\n') else {
                return Err(if line == 0 && !bytes.starts_with(b"ply") {
                    not_ply()
                } else {
                    ErrorKind::Corrupt("PLY header has no `end_header` line".into())
                });
            };
            let text = &bytes[pos..pos + end];
            pos += end + 1;
            line += 1;
            let syntax = |message: String| ErrorKind::Syntax { line, message };
            let mut words = text
                .split(u8::is_ascii_whitespace)
                .filter(|w| !w.is_empty());
            let keyword = words.next().unwrap_or_default();
            if line == 1 {
                if keyword != b"ply" || words.next().is_some() {
                    return Err(not_ply());
                }
                continue;
            }
            let args: Vec<&[u8]> = words.collect();
            match keyword {
                b"format" => {
                    let encoding = match args.first().copied() {
                        Some(b"ascii") => Encoding::Ascii,
                        Some(b"binary_little_endian") => Encoding::BinaryLittleEndian,
                        Some(b"binary_big_endian") => Encoding::BinaryBigEndian,
                        _ => return Err(syntax(format!("unknown format `{}`", lossy(text)))),
                    };
                    let version = args.get(1).and_then(|v| parse::<f64>(v));
                    if args.len() != 2 || version != Some(1.0) {
                        return Err(syntax(format!("expected `format {} 1.0`", lossy(args[0]))));
                    }
                    if format.replace(encoding).is_some() {
                        return Err(syntax("second `format` line".into()));
                    }
                }
                b"element" => {
                    let [name, count] = args[..] else {
                        return Err(syntax("expected `element NAME COUNT`".into()));
                    };
                    let count = parse::<usize>(count).ok_or_else(|| {
                        syntax(format!("malformed element count `{}`", lossy(count)))
                    })?;
                    elements.push(Element {
                        name: lossy(name),
                        count,
                        properties: Vec::new(),
                    });
                }
                b"property" => {
                    let element = elements
                        .last_mut()
                        .ok_or_else(|| syntax("`property` before any `element`".into()))?;
                    let scalar = |name: &[u8]| {
                        Scalar::parse(name)
                            .ok_or_else(|| syntax(format!("unknown type `{}`", lossy(name))))
                    };
                    let (kind, name) = match args[..] {
                        [b"list", count, item, name] => {
                            let count = scalar(count)?;
                            if !count.is_integer() {
                                return Err(syntax("a list count must be an integer type".into()));
                            }
                            (
                                Kind::List {
                                    count,
                                    item: scalar(item)?,
                                },
                                name,
                            )
                        }
                        [ty, name] if ty != b"list" => (Kind::Scalar(scalar(ty)?), name),
                        _ => {
                            return Err(syntax(
                                "expected `property TYPE NAME` or `property list COUNT_TYPE ITEM_TYPE NAME`"
                                    .into(),
                            ));
                        }
                    };
                    element.properties.push(Property {
                        name: lossy(name),
                        kind,
                    });
                }
                b"comment" | b"obj_info" | b"" => {}
                b"end_header" => break,
                _ => return Err(syntax(format!("unknown header line `{}`", lossy(text)))),
            }
        }
        let format =
            format.ok_or_else(|| ErrorKind::Corrupt("PLY header has no `format` line".into()))?;
        Ok(Header {
            format,
            elements,
            body_start: pos,
            body_line: line + 1,
        })
    }
}

fn not_ply() -> ErrorKind {
    ErrorKind::Corrupt("not a PLY file (it must start with a `ply` line)".into())
}

fn lossy(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn parse<T: std::str::FromStr>(word: &[u8]) -> Option<T> {
    std::str::from_utf8(word).ok()?.parse().ok()
}

/// Why a value could not be read.
enum ReadError {
    /// The data ended.
    End,
    /// An ASCII word that is not a number of the property's type.
    Malformed { line: usize, word: String },
}

impl ReadError {
    fn describe(self, context: impl FnOnce() -> String) -> ErrorKind {
        match self {
            ReadError::End => ErrorKind::Corrupt(format!(
                "{}: the data ends early (truncated file?)",
                context()
            )),
            ReadError::Malformed { line, word } => ErrorKind::Syntax {
                line,
                message: format!("{}: malformed number `{word}`", context()),
            },
        }
    }
}

/// A source of property values in file order.
trait Values {
    /// Read one value; integers are exact in `f64` (PLY has no 64-bit integers).
    fn value(&mut self, ty: Scalar) -> Result<f64, ReadError>;
    /// Bytes not yet read.
    fn remaining(&self) -> usize;
}

struct Binary<'a> {
    data: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl<'a> Binary<'a> {
    fn new(data: &'a [u8], big_endian: bool) -> Self {
        Binary {
            data,
            pos: 0,
            big_endian,
        }
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], ReadError> {
        let bytes = self
            .data
            .get(self.pos..self.pos + N)
            .and_then(|b| <[u8; N]>::try_from(b).ok())
            .ok_or(ReadError::End)?;
        self.pos += N;
        Ok(bytes)
    }
}

impl Values for Binary<'_> {
    fn value(&mut self, ty: Scalar) -> Result<f64, ReadError> {
        macro_rules! read {
            ($t:ty) => {{
                let bytes = self.take()?;
                let value = if self.big_endian {
                    <$t>::from_be_bytes(bytes)
                } else {
                    <$t>::from_le_bytes(bytes)
                };
                f64::from(value)
            }};
        }
        Ok(match ty {
            Scalar::I8 => read!(i8),
            Scalar::U8 => read!(u8),
            Scalar::I16 => read!(i16),
            Scalar::U16 => read!(u16),
            Scalar::I32 => read!(i32),
            Scalar::U32 => read!(u32),
            Scalar::F32 => read!(f32),
            Scalar::F64 => read!(f64),
        })
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }
}

struct Ascii<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Ascii<'a> {
    fn new(data: &'a [u8], line: usize) -> Self {
        Ascii { data, pos: 0, line }
    }

    fn word(&mut self) -> Option<&'a [u8]> {
        while let Some(&b) = self.data.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            self.line += usize::from(b == b'\n');
            self.pos += 1;
        }
        let start = self.pos;
        while self
            .data
            .get(self.pos)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.data[start..self.pos])
    }
}

impl Values for Ascii<'_> {
    fn value(&mut self, ty: Scalar) -> Result<f64, ReadError> {
        let word = self.word().ok_or(ReadError::End)?;
        let value = if ty.is_integer() {
            parse::<i64>(word).map(|v| v as f64)
        } else {
            parse::<f64>(word)
        };
        value.ok_or_else(|| ReadError::Malformed {
            line: self.line,
            word: lossy(word),
        })
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }
}

/// What a vertex property means; the discriminant indexes the per-vertex value array.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Role {
    X,
    Y,
    Z,
    Nx,
    Ny,
    Nz,
    Red,
    Green,
    Blue,
    Alpha,
    U,
    V,
}

const ROLES: usize = 12;

impl Role {
    fn of(name: &str) -> Option<Role> {
        Some(match name {
            "x" => Role::X,
            "y" => Role::Y,
            "z" => Role::Z,
            "nx" => Role::Nx,
            "ny" => Role::Ny,
            "nz" => Role::Nz,
            "red" | "diffuse_red" => Role::Red,
            "green" | "diffuse_green" => Role::Green,
            "blue" | "diffuse_blue" => Role::Blue,
            "alpha" | "diffuse_alpha" => Role::Alpha,
            "u" | "s" | "texture_u" | "texture_s" => Role::U,
            "v" | "t" | "texture_v" | "texture_t" => Role::V,
            _ => return None,
        })
    }
}

/// How to read one vertex record.
struct VertexLayout {
    /// Per property: its role (if used) and the factor that maps it to its value range.
    roles: Vec<(Option<Role>, f64)>,
    has_normal: bool,
    has_color: bool,
    has_alpha: bool,
    has_uv: bool,
}

impl VertexLayout {
    fn new(element: &Element) -> Result<VertexLayout, ErrorKind> {
        let mut present = [false; ROLES];
        let mut roles = Vec::with_capacity(element.properties.len());
        for property in &element.properties {
            let role = Role::of(&property.name);
            let scale = match (role, property.kind) {
                (Some(Role::Red | Role::Green | Role::Blue | Role::Alpha), Kind::Scalar(ty)) => {
                    ty.color_scale()
                }
                _ => 1.0,
            };
            let role = match property.kind {
                Kind::Scalar(_) => role,
                Kind::List { .. } => None,
            };
            if let Some(role) = role
                && std::mem::replace(&mut present[role as usize], true)
            {
                return Err(ErrorKind::Corrupt(format!(
                    "vertex property `{}` appears twice",
                    property.name
                )));
            }
            roles.push((role, scale));
        }
        let all = |rs: &[Role]| rs.iter().all(|&r| present[r as usize]);
        if !all(&[Role::X, Role::Y, Role::Z]) {
            return Err(ErrorKind::Corrupt(
                "the vertex element needs scalar properties x, y and z".into(),
            ));
        }
        Ok(VertexLayout {
            roles,
            has_normal: all(&[Role::Nx, Role::Ny, Role::Nz]),
            has_color: all(&[Role::Red, Role::Green, Role::Blue]),
            has_alpha: present[Role::Alpha as usize],
            has_uv: all(&[Role::U, Role::V]),
        })
    }
}

/// Read every element in file order into a builder.
fn read_body<R: Values>(
    header: &Header,
    mut reader: R,
    limits: &Limits,
    warnings: &mut Vec<String>,
) -> Result<MeshBuilder, ErrorKind> {
    let mut vertex_elements = header.elements.iter().filter(|e| e.name == "vertex");
    let vertex_element = vertex_elements
        .next()
        .ok_or_else(|| ErrorKind::Corrupt("the PLY file has no vertex element".into()))?;
    if vertex_elements.next().is_some() {
        return Err(ErrorKind::Corrupt(
            "the PLY file has more than one vertex element".into(),
        ));
    }
    let vertex_count = vertex_element.count;
    if u32::try_from(vertex_count).is_err() {
        return Err(ErrorKind::Corrupt(format!(
            "{vertex_count} vertices are more than this loader supports"
        )));
    }
    let layout = VertexLayout::new(vertex_element)?;
    if !header.elements.iter().any(|e| e.name == "face") {
        return Err(ErrorKind::Empty(
            " (no face element: point clouds are not supported)".into(),
        ));
    }

    let mut builder = MeshBuilder::default();
    let mut faces_seen = false;
    for element in &header.elements {
        // The last ASCII record needs no separator after it.
        let slack = usize::from(header.format == Encoding::Ascii);
        let fits = element
            .count
            .checked_mul(element.min_record_size(header.format))
            .is_some_and(|need| need <= reader.remaining() + slack);
        if !fits {
            return Err(ErrorKind::Corrupt(format!(
                "element `{}` claims {} records, more than the {} bytes left can hold",
                element.name,
                element.count,
                reader.remaining()
            )));
        }
        if element.properties.is_empty() {
            continue;
        }
        match element.name.as_str() {
            "vertex" => {
                builder.check_room(element.count, 0, limits)?;
                read_vertices(element, &layout, &mut reader, &mut builder)?
            }
            "face" if !faces_seen => {
                faces_seen = true;
                builder.check_room(0, element.count, limits)?;
                let faces = Faces {
                    vertex_count,
                    limits: *limits,
                };
                read_faces(element, faces, &mut reader, &mut builder, warnings)?;
            }
            _ => {
                for i in 0..element.count {
                    for property in &element.properties {
                        skip(property.kind, &mut reader)
                            .map_err(|e| e.describe(|| format!("{} {i}", element.name)))?;
                    }
                }
            }
        }
    }
    Ok(builder)
}

/// Read (and drop) one property value.
fn skip<R: Values>(kind: Kind, reader: &mut R) -> Result<(), ReadError> {
    match kind {
        Kind::Scalar(ty) => reader.value(ty).map(drop),
        Kind::List { count, item } => {
            let n = list_length(reader.value(count)?);
            for _ in 0..n {
                reader.value(item)?;
            }
            Ok(())
        }
    }
}

/// A list length as read; negative counts are treated as empty lists by `skip` and rejected
/// for faces.
fn list_length(value: f64) -> usize {
    if value > 0.0 { value as usize } else { 0 }
}

fn read_vertices<R: Values>(
    element: &Element,
    layout: &VertexLayout,
    reader: &mut R,
    builder: &mut MeshBuilder,
) -> Result<(), ErrorKind> {
    builder.positions.reserve(element.count);
    // uchar colours are by far the most common: convert through a table.
    let srgb_u8: Vec<f32> = (0..=255)
        .map(|c| ori_math::srgb_to_linear(f64::from(c) / 255.0) as f32)
        .collect();
    let srgb = |c: f64| {
        let byte = (c * 255.0).round();
        if (c * 255.0 - byte).abs() < 1e-6 && (0.0..=255.0).contains(&byte) {
            srgb_u8[byte as usize]
        } else {
            ori_math::srgb_to_linear(c) as f32
        }
    };
    for i in 0..element.count {
        let context = || format!("vertex {i}");
        let mut v = [0.0f64; ROLES];
        for (property, &(role, scale)) in element.properties.iter().zip(&layout.roles) {
            match (property.kind, role) {
                (Kind::Scalar(ty), Some(role)) => {
                    v[role as usize] = reader.value(ty).map_err(|e| e.describe(context))? * scale;
                }
                (kind, _) => skip(kind, reader).map_err(|e| e.describe(context))?,
            }
        }
        let at = |r: Role| v[r as usize];
        let position = [at(Role::X), at(Role::Y), at(Role::Z)].map(|c| c as f32);
        let normal = layout
            .has_normal
            .then(|| [at(Role::Nx), at(Role::Ny), at(Role::Nz)].map(|c| c as f32));
        let uv = layout
            .has_uv
            .then(|| [at(Role::U) as f32, 1.0 - at(Role::V) as f32]);
        let color = layout.has_color.then(|| {
            let alpha = if layout.has_alpha {
                at(Role::Alpha).clamp(0.0, 1.0) as f32
            } else {
                1.0
            };
            [
                srgb(at(Role::Red)),
                srgb(at(Role::Green)),
                srgb(at(Role::Blue)),
                alpha,
            ]
        });
        let finite = |values: &[f32]| values.iter().all(|c| c.is_finite());
        if !uv.is_none_or(|uv| finite(&uv)) || !color.is_none_or(|c| finite(&c)) {
            return Err(ErrorKind::Corrupt(format!(
                "vertex {i}: non-finite colour or texture coordinate"
            )));
        }
        builder.push_vertex(position, normal, uv, color);
    }
    Ok(())
}

/// What face indices are checked against.
#[derive(Clone, Copy)]
struct Faces {
    vertex_count: usize,
    limits: Limits,
}

fn read_faces<R: Values>(
    element: &Element,
    Faces {
        vertex_count,
        limits,
    }: Faces,
    reader: &mut R,
    builder: &mut MeshBuilder,
    warnings: &mut Vec<String>,
) -> Result<(), ErrorKind> {
    let (indices, count_type, index_type) = element
        .properties
        .iter()
        .enumerate()
        .find_map(|(i, p)| match p.kind {
            Kind::List { count, item }
                if p.name == "vertex_indices" || p.name == "vertex_index" =>
            {
                Some((i, count, item))
            }
            _ => None,
        })
        .ok_or_else(|| {
            ErrorKind::Corrupt("the face element has no `vertex_indices` list".into())
        })?;
    if !index_type.is_integer() {
        return Err(ErrorKind::Corrupt(
            "face `vertex_indices` must have an integer item type".into(),
        ));
    }
    let ignored: Vec<&str> = element
        .properties
        .iter()
        .enumerate()
        .filter(|&(i, _)| i != indices)
        .map(|(_, p)| p.name.as_str())
        .collect();
    if !ignored.is_empty() {
        warnings.push(format!(
            "ignored PLY face properties: {}",
            ignored.join(", ")
        ));
    }
    builder.triangles.reserve(element.count);
    for i in 0..element.count {
        let context = || format!("face {i}");
        for (p, property) in element.properties.iter().enumerate() {
            if p != indices {
                skip(property.kind, reader).map_err(|e| e.describe(context))?;
                continue;
            }
            let n = reader.value(count_type).map_err(|e| e.describe(context))?;
            if n < 3.0 {
                return Err(ErrorKind::Corrupt(format!(
                    "face {i} has {n} corners (at least 3 are needed)"
                )));
            }
            if n > limits.max_face_corners as f64 {
                return Err(ErrorKind::Limit {
                    what: format!("face {i}: its corner count"),
                    value: n as u64,
                    limit: limits.max_face_corners as u64,
                    key: "[limits] max_face_corners",
                });
            }
            builder.check_room(0, n as usize - 2, &limits)?;
            let mut corner = || -> Result<u32, ErrorKind> {
                let index = reader.value(index_type).map_err(|e| e.describe(context))?;
                if index >= 0.0 && index < vertex_count as f64 {
                    Ok(index as u32)
                } else {
                    Err(ErrorKind::IndexOutOfRange {
                        context: context(),
                        index: index as i64,
                        count: vertex_count,
                    })
                }
            };
            let first = corner()?;
            let mut previous = corner()?;
            for _ in 2..n as usize {
                let next = corner()?;
                builder.push_triangle([first, previous, next], 0);
                previous = next;
            }
        }
    }
    Ok(())
}
