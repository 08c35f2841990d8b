//! PLY, ASCII and binary little endian. Reads `vertex` (x, y, z) and `face` (a list property
//! `vertex_indices` or `vertex_index`); skips other elements and properties.

use super::{Encoding, FormatError, text};
use crate::mesh::TriMesh;
use nalgebra::Point3;
use std::fmt::Write;

const F: &str = "PLY";

#[derive(Debug, Clone, Copy, PartialEq)]
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
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
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
    fn read_le(self, b: &[u8]) -> f64 {
        match self {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
            Scalar::U32 => u32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
            Scalar::F32 => f32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
            Scalar::F64 => f64::from_le_bytes(b[..8].try_into().unwrap()),
        }
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar {
        name: String,
        ty: Scalar,
    },
    List {
        name: String,
        count: Scalar,
        item: Scalar,
    },
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Body {
    Ascii,
    BinaryLe,
}

struct Header {
    body: Body,
    elements: Vec<Element>,
    /// Byte offset of the body, and the number of header lines.
    offset: usize,
    lines: usize,
}

fn parse_header(bytes: &[u8]) -> Result<Header, FormatError> {
    if bytes.is_empty() {
        return Err(FormatError {
            format: F,
            line: None,
            byte: None,
            message: "file is empty; expected a PLY header".into(),
        });
    }
    let mut pos = 0;
    let mut ln = 0;
    let mut body = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let end = bytes[pos..]
            .iter()
            .position(|&c| c == b'\n')
            .ok_or_else(|| {
                FormatError::at_line(
                    F,
                    ln + 1,
                    "header has no 'end_header'; truncated or not a PLY",
                )
            })?;
        let line = String::from_utf8_lossy(&bytes[pos..pos + end])
            .trim()
            .to_string();
        pos += end + 1;
        ln += 1;
        let toks: Vec<&str> = line.split_whitespace().collect();
        if ln == 1 {
            if toks.first() != Some(&"ply") {
                return Err(FormatError::at_line(
                    F,
                    1,
                    format!("first line is '{line}'; expected 'ply'"),
                ));
            }
            continue;
        }
        match toks.as_slice() {
            ["format", "ascii", _] => body = Some(Body::Ascii),
            ["format", "binary_little_endian", _] => body = Some(Body::BinaryLe),
            ["format", other, ..] => {
                return Err(FormatError::at_line(
                    F,
                    ln,
                    format!(
                        "format '{other}' is not supported; expected ascii or binary_little_endian"
                    ),
                ));
            }
            ["element", name, count] => {
                let count = count.parse::<usize>().map_err(|_| {
                    FormatError::at_line(
                        F,
                        ln,
                        format!("element count '{count}'; expected a non-negative integer"),
                    )
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            ["property", "list", c, i, name] => {
                let (Some(count), Some(item)) = (Scalar::parse(c), Scalar::parse(i)) else {
                    return Err(FormatError::at_line(
                        F,
                        ln,
                        format!("list property types '{c} {i}' are not PLY types"),
                    ));
                };
                let el = elements
                    .last_mut()
                    .ok_or_else(|| FormatError::at_line(F, ln, "property before any element"))?;
                el.props.push(Property::List {
                    name: name.to_string(),
                    count,
                    item,
                });
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty).ok_or_else(|| {
                    FormatError::at_line(F, ln, format!("property type '{ty}' is not a PLY type"))
                })?;
                let el = elements
                    .last_mut()
                    .ok_or_else(|| FormatError::at_line(F, ln, "property before any element"))?;
                el.props.push(Property::Scalar {
                    name: name.to_string(),
                    ty,
                });
            }
            ["end_header"] => break,
            ["comment", ..] | ["obj_info", ..] | [] => {}
            _ => {
                return Err(FormatError::at_line(
                    F,
                    ln,
                    format!("unexpected header line '{line}'"),
                ));
            }
        }
    }
    let body = body.ok_or_else(|| FormatError::at_line(F, ln, "header has no 'format' line"))?;
    Ok(Header {
        body,
        elements,
        offset: pos,
        lines: ln,
    })
}

pub fn read_ply(bytes: &[u8]) -> Result<TriMesh, FormatError> {
    let h = parse_header(bytes)?;
    for el in &h.elements {
        if el.name == "vertex" {
            for axis in ["x", "y", "z"] {
                if !el
                    .props
                    .iter()
                    .any(|p| matches!(p, Property::Scalar { name, .. } if name == axis))
                {
                    return Err(FormatError::at_line(
                        F,
                        h.lines,
                        format!("vertex element has no '{axis}' property"),
                    ));
                }
            }
        }
    }
    let mut sink = Sink::default();
    match h.body {
        Body::Ascii => read_ascii_body(&bytes[h.offset..], &h, &mut sink)?,
        Body::BinaryLe => read_binary_body(bytes, &h, &mut sink)?,
    }
    let n = sink.positions.len();
    for (f, face) in sink.faces.iter().enumerate() {
        if let Some(&v) = face.iter().find(|&&v| v as usize >= n) {
            return Err(FormatError {
                format: F,
                line: None,
                byte: None,
                message: format!("face {f} refers to vertex {v}, but there are {n} vertices"),
            });
        }
    }
    Ok(TriMesh::new(sink.positions, sink.faces))
}

#[derive(Default)]
struct Sink {
    positions: Vec<Point3<f64>>,
    faces: Vec<[u32; 3]>,
}

impl Sink {
    fn vertex(&mut self, el: &Element, values: &[f64]) {
        let mut p = [0.0; 3];
        for (prop, v) in el.props.iter().zip(values) {
            if let Property::Scalar { name, .. } = prop {
                match name.as_str() {
                    "x" => p[0] = *v,
                    "y" => p[1] = *v,
                    "z" => p[2] = *v,
                    _ => {}
                }
            }
        }
        self.positions.push(Point3::from(p));
    }
    fn face(
        &mut self,
        idx: &[f64],
        err: impl Fn(String) -> FormatError,
    ) -> Result<(), FormatError> {
        if idx.len() < 3 {
            return Err(err(format!(
                "face has {} vertices; expected at least 3",
                idx.len()
            )));
        }
        if let Some(bad) = idx
            .iter()
            .find(|&&v| v < 0.0 || v > u32::MAX as f64 - 1.0 || v.fract() != 0.0)
        {
            return Err(err(format!(
                "face index {bad}; expected a non-negative integer"
            )));
        }
        for k in 1..idx.len() - 1 {
            self.faces
                .push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
        }
        Ok(())
    }
}

fn is_face_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

fn read_ascii_body(body: &[u8], h: &Header, sink: &mut Sink) -> Result<(), FormatError> {
    let src = text(body);
    let mut lines = src.lines().enumerate().map(|(i, l)| (i + 1 + h.lines, l));
    for el in &h.elements {
        for _ in 0..el.count {
            let (ln, line) = lines.next().ok_or_else(|| {
                FormatError::at_line(
                    F,
                    h.lines + 1,
                    format!(
                        "file ends before {} '{}' records; truncated",
                        el.count, el.name
                    ),
                )
            })?;
            let mut toks = line.split_whitespace();
            let mut num = |what: &str| -> Result<f64, FormatError> {
                super::parse_f64(F, ln, toks.next(), what)
            };
            let mut scalars = Vec::new();
            let mut list = Vec::new();
            for prop in &el.props {
                match prop {
                    Property::Scalar { name, .. } => scalars.push(num(name)?),
                    Property::List { name, .. } => {
                        let n = num("list count")?;
                        if !(0.0..=1e6).contains(&n) {
                            return Err(FormatError::at_line(
                                F,
                                ln,
                                format!("list count {n}; expected 0 to 1000000"),
                            ));
                        }
                        let mut items = Vec::new();
                        for _ in 0..n as usize {
                            items.push(num("list item")?);
                        }
                        if is_face_list(name) {
                            list = items;
                        }
                    }
                }
            }
            match el.name.as_str() {
                "vertex" => sink.vertex(el, &scalars),
                "face" => sink.face(&list, |m| FormatError::at_line(F, ln, m))?,
                _ => {}
            }
        }
    }
    Ok(())
}

fn read_binary_body(bytes: &[u8], h: &Header, sink: &mut Sink) -> Result<(), FormatError> {
    let mut pos = h.offset;
    let take = |pos: &mut usize, n: usize| -> Result<&[u8], FormatError> {
        if bytes.len() - *pos < n {
            return Err(FormatError::at_byte(
                F,
                *pos,
                format!(
                    "file ends {} bytes short; truncated",
                    n - (bytes.len() - *pos)
                ),
            ));
        }
        *pos += n;
        Ok(&bytes[*pos - n..*pos])
    };
    for el in &h.elements {
        // Fixed-size records: the whole element must fit before any allocation.
        if el
            .props
            .iter()
            .all(|p| matches!(p, Property::Scalar { .. }))
        {
            let rec: usize = el
                .props
                .iter()
                .map(|p| {
                    if let Property::Scalar { ty, .. } = p {
                        ty.size()
                    } else {
                        0
                    }
                })
                .sum();
            let need = (el.count as u128) * rec as u128;
            if need > (bytes.len() - pos) as u128 {
                return Err(FormatError::at_byte(
                    F,
                    pos,
                    format!(
                        "element '{}' claims {} records ({need} bytes) but {} bytes remain; truncated or lying header",
                        el.name,
                        el.count,
                        bytes.len() - pos
                    ),
                ));
            }
        }
        for _ in 0..el.count {
            let mut scalars = Vec::with_capacity(el.props.len());
            let mut list = Vec::new();
            for prop in &el.props {
                match prop {
                    Property::Scalar { ty, .. } => {
                        scalars.push(ty.read_le(take(&mut pos, ty.size())?))
                    }
                    Property::List { name, count, item } => {
                        let n = count.read_le(take(&mut pos, count.size())?);
                        if n < 0.0 {
                            return Err(FormatError::at_byte(
                                F,
                                pos,
                                format!("list count {n}; expected non-negative"),
                            ));
                        }
                        let raw = take(&mut pos, n as usize * item.size())?;
                        if is_face_list(name) {
                            list = raw
                                .chunks_exact(item.size())
                                .map(|c| item.read_le(c))
                                .collect();
                        }
                    }
                }
            }
            let at = pos;
            match el.name.as_str() {
                "vertex" => sink.vertex(el, &scalars),
                "face" => sink.face(&list, |m| FormatError::at_byte(F, at, m))?,
                _ => {}
            }
        }
    }
    Ok(())
}

pub fn write_ply(mesh: &TriMesh, encoding: Encoding) -> Vec<u8> {
    let fmt = match encoding {
        Encoding::Ascii => "ascii",
        Encoding::Binary => "binary_little_endian",
    };
    let mut s = format!(
        "ply\nformat {fmt} 1.0\ncomment waamtwin mesh, mm\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.n_vertices(),
        mesh.n_faces()
    );
    match encoding {
        Encoding::Ascii => {
            for p in &mesh.positions {
                let _ = writeln!(s, "{:e} {:e} {:e}", p.x, p.y, p.z);
            }
            for f in &mesh.faces {
                let _ = writeln!(s, "3 {} {} {}", f[0], f[1], f[2]);
            }
            s.into_bytes()
        }
        Encoding::Binary => {
            let mut out = s.into_bytes();
            for p in &mesh.positions {
                for k in 0..3 {
                    out.extend_from_slice(&p[k].to_le_bytes());
                }
            }
            for f in &mesh.faces {
                out.push(3);
                for v in f {
                    out.extend_from_slice(&(*v as i32).to_le_bytes());
                }
            }
            out
        }
    }
}
