//! The structs shared with GLSL. A GPU round trip: what the shader sees of each member of
//! `RenderParams`, and where its writes of `Pixel` land (output buffers start filled with a
//! sentinel so a member the shader never wrote differs from one written as 0). And, without a GPU, SPIR-V
//! reflection of every shader: each of the 10 Rust mirrors against its GLSL declaration in
//! every shader that has one (members, offsets, sizes, scalar types), and every shader's
//! workgroup size against the constant its dispatch divides by.

use isoview::frame::Pixel;
use isoview::gpu::{vk, Binding, Buffer, ComputePipeline, MemoryLocation, Resource, Tracker};
use isoview::render::params::RenderParams;
use isoview::shaders;

use crate::common::gpu;

const SENTINEL: u32 = 0xDEAD_BEEF;

#[gpu_test]
fn shared_structs_have_the_same_layout_on_the_gpu() {
    let ctx = gpu();
    let mut params = RenderParams::default();
    // Distinct bits in every 4-byte slot.
    let words: &mut [u32] = bytemuck::cast_slice_mut(std::slice::from_mut(&mut params));
    for (i, w) in words.iter_mut().enumerate() {
        *w = 0x4000_0000 + i as u32 * 7919;
    }
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::UNIFORM_BUFFER;
    let bytes = std::mem::size_of::<RenderParams>() as u64;
    let words = bytes as usize / 4;
    let mut ubo =
        Buffer::new(&ctx, "probe params", bytes, usage, MemoryLocation::CpuToGpu).unwrap();
    ubo.write(std::slice::from_ref(&params)).unwrap();
    let mut bits = Buffer::new(&ctx, "probe bits", bytes, usage, MemoryLocation::GpuToCpu).unwrap();
    bits.write(&vec![SENTINEL; words]).unwrap();
    let mut px = Buffer::new(&ctx, "probe pixels", 160, usage, MemoryLocation::GpuToCpu).unwrap();
    px.write(&[SENTINEL; 40]).unwrap();

    let pipeline = ComputePipeline::new(
        &ctx,
        "layout probe",
        shaders::TEST_LAYOUT_PROBE,
        &[Binding::Uniform, Binding::Write, Binding::Write],
        0,
    )
    .unwrap();
    let set = pipeline
        .bind(&[Resource::Uniform(&ubo), Resource::Storage(&bits), Resource::Storage(&px)])
        .unwrap();
    ctx.record("layout probe", &mut Tracker::default(), |rec| {
        rec.dispatch(&pipeline, &set, &[], [1, 1, 1]);
        rec.host_read(&bits);
        rec.host_read(&px);
        Ok(())
    })
    .unwrap();

    // Member by member: the probe writes each one's bits back to back in declaration order.
    let seen: Vec<u32> = bits.read(words).unwrap();
    let sent: &[u32] = bytemuck::cast_slice(std::slice::from_ref(&params));
    let (_, size, fields) = render_params();
    assert_eq!(fields.iter().map(|f| f.size).sum::<usize>(), size, "fields cover the struct");
    let wrong: Vec<String> = fields
        .iter()
        .filter_map(|f| {
            let words = f.offset / 4..(f.offset + f.size) / 4;
            let (got, want) = (&seen[words.clone()], &sent[words]);
            (got != want).then(|| format!("{}: GLSL read {got:x?}, Rust wrote {want:x?}", f.name))
        })
        .collect();
    assert!(wrong.is_empty(), "RenderParams as GLSL reads it:\n{}", wrong.join("\n"));

    let pixels: Vec<Pixel> = px.read(2).unwrap();
    let untouched: &[u32] = bytemuck::cast_slice(std::slice::from_ref(&pixels[0]));
    assert!(untouched.iter().all(|&w| w == SENTINEL), "pixel 0 must stay unwritten");
    assert_eq!(
        pixels[1],
        Pixel {
            rgba: [1.0, 2.0, 3.0, 4.0],
            normal: [5.0, 6.0, 7.0],
            depth: 8.0,
            position: [9.0, 10.0, 11.0],
            steps: 12.0,
            cell: [13, 14, 15],
            crossings: 16,
            surface: 17,
            value: 18.0,
            pad: [19, 20],
        }
    );
}

// ---------------------------------------------------------------------------------------------
// SPIR-V reflection: every struct shared with GLSL, in every shader that declares it.
//
// The shaders are compiled with debug info (build.rs), so their SPIR-V names each struct and
// member. For each Rust mirror, every shader holding a laid-out struct of the GLSL name (one
// with `Offset` decorations) must have the same members in the same order, at the Rust
// offsets, with the Rust sizes and scalar types, and the same total size.

use std::collections::HashMap;

use isoview::passes::{self, Band};

/// What a SPIR-V module says about its types (only what the layout check needs).
#[derive(Default)]
struct Module {
    names: HashMap<u32, String>,
    member_names: HashMap<(u32, u32), String>,
    offsets: HashMap<(u32, u32), u32>,
    array_strides: HashMap<u32, u32>,
    types: HashMap<u32, Type>,
    constants: HashMap<u32, u32>,
    /// `LocalSize` of the entry point.
    local_size: Option<[u32; 3]>,
}

#[derive(Clone, Debug)]
enum Type {
    Scalar { kind: &'static str, bytes: u32 },
    Vector { component: u32, count: u32 },
    Array { element: u32, length: Option<u32> },
    Struct { members: Vec<u32> },
    Other,
}

fn string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

/// A minimal SPIR-V word reader: names, decorations, types, constants, the local size.
fn parse(spirv: &[u8]) -> Module {
    let words: Vec<u32> =
        spirv.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(words[0], 0x0723_0203, "not SPIR-V");
    let mut m = Module::default();
    let mut at = 5;
    while at < words.len() {
        let (count, op) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        let w = &words[at + 1..at + count];
        match op {
            5 => drop(m.names.insert(w[0], string(&w[1..]))),
            6 => drop(m.member_names.insert((w[0], w[1]), string(&w[2..]))),
            16 if w[1] == 17 => m.local_size = Some([w[2], w[3], w[4]]),
            71 if w[1] == 6 => drop(m.array_strides.insert(w[0], w[2])),
            72 if w[2] == 35 => drop(m.offsets.insert((w[0], w[1]), w[3])),
            21 => {
                let kind = if w[2] == 1 { "i" } else { "u" };
                m.types.insert(w[0], Type::Scalar { kind, bytes: w[1] / 8 });
            }
            22 => drop(m.types.insert(w[0], Type::Scalar { kind: "f", bytes: w[1] / 8 })),
            23 => drop(m.types.insert(w[0], Type::Vector { component: w[1], count: w[2] })),
            28 => drop(m.types.insert(w[0], Type::Array { element: w[1], length: Some(w[2]) })),
            29 => drop(m.types.insert(w[0], Type::Array { element: w[1], length: None })),
            30 => drop(m.types.insert(w[0], Type::Struct { members: w[1..].to_vec() })),
            43 => drop(m.constants.insert(w[1], w[2])),
            19..=39 => drop(m.types.insert(w[0], Type::Other)),
            _ => {}
        }
        at += count.max(1);
    }
    m
}

/// One member of a laid-out GLSL struct.
#[derive(Debug)]
struct Member {
    name: String,
    offset: u32,
    size: u32,
    /// Scalar type of its elements: `f32`, `i32`, `u32`, ...
    scalar: String,
}

impl Module {
    /// Bytes the type occupies (arrays by their stride), and its scalar element type.
    fn size(&self, id: u32) -> (u32, String) {
        match &self.types[&id] {
            Type::Scalar { kind, bytes } => (*bytes, format!("{kind}{}", bytes * 8)),
            Type::Vector { component, count } => {
                let (s, k) = self.size(*component);
                (s * count, k)
            }
            Type::Array { element, length } => {
                let (s, k) = self.size(*element);
                let stride = self.array_strides.get(&id).copied().unwrap_or(s);
                let n = length.map_or(0, |l| self.constants[&l]);
                (stride * n, k)
            }
            Type::Struct { members } => {
                let end = (0..members.len() as u32)
                    .map(|i| {
                        self.offsets.get(&(id, i)).copied().unwrap_or(0)
                            + self.size(members[i as usize]).0
                    })
                    .max()
                    .unwrap_or(0);
                (end, "struct".into())
            }
            Type::Other => (0, "other".into()),
        }
    }

    /// Every laid-out struct named `name`: its members and its size.
    fn structs(&self, name: &str) -> Vec<(Vec<Member>, u32)> {
        let mut out = Vec::new();
        for (&id, t) in &self.types {
            let Type::Struct { members } = t else { continue };
            if self.names.get(&id).map(String::as_str) != Some(name)
                || !self.offsets.contains_key(&(id, 0))
            {
                continue;
            }
            let list: Vec<Member> = members
                .iter()
                .enumerate()
                .map(|(i, &ty)| {
                    let (size, scalar) = self.size(ty);
                    Member {
                        name: self.member_names.get(&(id, i as u32)).cloned().unwrap_or_default(),
                        offset: self.offsets[&(id, i as u32)],
                        size,
                        scalar,
                    }
                })
                .collect();
            out.push((list, self.size(id).0));
        }
        out
    }
}

/// A Rust mirror: its name, size and fields.
type Mirror = (&'static str, usize, Vec<Field>);

/// A struct to check: the Rust mirror, the GLSL struct name, which shaders (by path under
/// `shaders/`), and how many declarations at least must be found.
type Spec<'a> = (Mirror, &'static str, &'a dyn Fn(&str) -> bool, usize);

/// One field of a Rust mirror: its name, the GLSL members it covers, offset, size, scalar.
struct Field {
    name: &'static str,
    glsl: Vec<&'static str>,
    offset: usize,
    size: usize,
    scalar: String,
}

/// The scalar type of a Rust field type's name: `[[i32; 16]; 256]` -> `i32`.
fn scalar_of(type_name: &str) -> String {
    type_name.trim_start_matches('[').split([';', ']']).next().unwrap().to_string()
}

/// A Rust mirror's fields: `rust_struct!(Pixel { rgba, normal, ... })`; a field covering
/// several GLSL members names them: `pad => ["pad0", "pad1"]`.
macro_rules! rust_struct {
    ($t:ty { $($field:ident $(=> [$($glsl:literal),+])?),+ $(,)? }) => {{
        let z: $t = bytemuck::Zeroable::zeroed();
        let fields = vec![$(Field {
            name: stringify!($field),
            glsl: {
                let named: Vec<&'static str> = vec![$($($glsl),+)?];
                if named.is_empty() { vec![stringify!($field)] } else { named }
            },
            offset: std::mem::offset_of!($t, $field),
            size: std::mem::size_of_val(&z.$field),
            scalar: scalar_of(std::any::type_name_of_val(&z.$field)),
        }),+];
        (stringify!($t), std::mem::size_of::<$t>(), fields)
    }};
}

/// `RenderParams`, every named member (each `padN` too: GLSL declares them).
fn render_params() -> Mirror {
    rust_struct!(RenderParams {
        eye,
        pad0,
        forward,
        pad1,
        right,
        pad2,
        up,
        pad3,
        box_min,
        pad4,
        box_max,
        pad5,
        inv_spacing,
        pad6,
        eye_grid,
        pad7,
        dims,
        pad8,
        block_lo,
        pad9,
        block_hi,
        pad10,
        block_origin,
        pad11,
        background,
        color,
        pad12,
        width,
        height,
        stride,
        picture_width,
        shading,
        steps,
        newton_steps,
        normals,
        threshold,
        inside_sign,
        depth_near,
        depth_far,
        steps_scale,
        crossing,
        skip,
        count_crossings,
        orthographic,
        clip_count,
        surfaces,
        pad13,
        clip,
        thresholds,
        surface_color
    })
}

/// Compares one Rust mirror with one GLSL struct; returns the differences found.
fn differences(rust: &Mirror, glsl: &(Vec<Member>, u32), shader: &str) -> Vec<String> {
    let (name, size, fields) = rust;
    let (members, glsl_size) = glsl;
    let mut out = Vec::new();
    let want: Vec<&str> = fields.iter().flat_map(|f| f.glsl.iter().copied()).collect();
    let have: Vec<&str> = members.iter().map(|m| m.name.as_str()).collect();
    if want != have {
        out.push(format!("{shader}: {name} members {have:?}, Rust mirrors {want:?}"));
        return out;
    }
    if *glsl_size as usize != *size {
        out.push(format!("{shader}: {name} is {glsl_size} bytes in GLSL, {size} in Rust"));
    }
    let mut i = 0;
    for f in fields {
        let span = &members[i..i + f.glsl.len()];
        i += f.glsl.len();
        let (first, last) = (&span[0], &span[span.len() - 1]);
        let glsl_span = (last.offset + last.size - first.offset) as usize;
        if first.offset as usize != f.offset || glsl_span != f.size {
            out.push(format!(
                "{shader}: {name}.{} at offset {} ({} bytes) in GLSL, {} ({} bytes) in Rust",
                f.name, first.offset, glsl_span, f.offset, f.size
            ));
        }
        if let Some(m) = span.iter().find(|m| m.scalar != f.scalar) {
            out.push(format!(
                "{shader}: {name}.{}: GLSL {} is {}, Rust has {}",
                f.name, m.name, m.scalar, f.scalar
            ));
        }
    }
    out
}

#[test]
fn every_shared_struct_matches_its_glsl_in_every_shader() {
    use isoview::frame::Pixel;
    use isoview::passes::bricks::{Shape, SuperShape};
    use isoview::passes::extract::{ExtractParams, ExtractTables, ScanPush, SlabPush};
    use isoview::passes::mesh_render::RasterPush;
    use isoview::passes::slice::{SliceParams, SlicePixel};

    let extract = |p: &str| p.starts_with("extract/") && !p.starts_with("extract/scan");
    let any = |_: &str| true;
    // (Rust mirror, GLSL struct name, which shaders, how many at least must declare it).
    let specs: Vec<Spec> = vec![
        (render_params(), "RenderParams", &any, 5),
        (
            rust_struct!(Pixel {
                rgba,
                normal,
                depth,
                position,
                steps,
                cell,
                crossings,
                surface,
                value,
                pad => ["pad0", "pad1"]
            }),
            "Pixel",
            &any,
            4,
        ),
        (rust_struct!(Band { row_offset, rows }), "Band", &any, 4),
        (
            rust_struct!(RasterPush {
                row_offset,
                rows,
                triangle_count,
                threads_x,
                chunk_pixels,
                stage
            }),
            "Push",
            &|p: &str| p == "mesh_raster.comp",
            1,
        ),
        (rust_struct!(Shape { points, bricks }), "Shape", &any, 1),
        (rust_struct!(SuperShape { supers, bricks }), "SuperShape", &any, 1),
        (
            rust_struct!(ExtractParams { dims, box_min, spacing, iso, iso_bits }),
            "Params",
            &extract,
            9,
        ),
        (
            rust_struct!(SlabPush {
                groups_x,
                count,
                z0,
                point_z0,
                cell_z0,
                owned_point,
                owned_cell,
                vertex_base,
                mode,
                value_z0,
                owned_point_end,
                owned_cell_end,
                added_base,
                added_offset
            }),
            "Push",
            &extract,
            10,
        ),
        (
            rust_struct!(ScanPush { groups_x, count }),
            "Push",
            &|p: &str| p.starts_with("extract/scan"),
            2,
        ),
        (
            rust_struct!(ExtractTables {
                mc_triangles,
                mc_edges,
                mc_vertex_corner,
                mt_tets,
                mt_tet_edges,
                mt_triangles,
                mc_edge_index
            }),
            "Tables",
            &extract,
            5,
        ),
        (
            rust_struct!(SliceParams { axes, dims, image, plane, scale, line }),
            "SliceParams",
            &any,
            1,
        ),
        (
            rust_struct!(SlicePixel { rgba, value, contour, pad => ["pad0", "pad1"] }),
            "SlicePixel",
            &any,
            1,
        ),
    ];
    let modules: Vec<(&str, Module)> =
        shaders::ALL.iter().map(|(path, spv)| (*path, parse(spv))).collect();
    let mut problems = Vec::new();
    for (rust, glsl_name, in_shader, at_least) in &specs {
        let mut found = 0;
        for (path, module) in modules.iter().filter(|(p, _)| in_shader(p)) {
            for s in module.structs(glsl_name) {
                found += 1;
                problems.extend(differences(rust, &s, path));
            }
        }
        if found < *at_least {
            problems.push(format!(
                "{}: found as {glsl_name:?} in {found} shaders, expected at least {at_least}",
                rust.0
            ));
        }
        eprintln!("{}: checked against {found} shader declarations", rust.0);
    }
    assert!(problems.is_empty(), "layout mismatches:\n{}", problems.join("\n"));
}

/// Every shader's workgroup size is the constant its Rust dispatch divides by (both come
/// from build.rs's table; this catches a shader that writes a literal instead).
#[test]
fn workgroup_sizes_are_the_dispatch_constants() {
    use isoview::shaders::consts;
    let ray = passes::raymarch::GROUP;
    for (path, spv) in shaders::ALL {
        let want = match *path {
            "raymarch.comp" | "analytic.comp" | "voxels.comp" | "tricubic.comp" => [ray, ray, 1],
            "mesh_resolve.comp" => {
                let g = passes::mesh_render::RESOLVE_GROUP;
                [g, g, 1]
            }
            "mesh_raster.comp" => [passes::mesh_render::RASTER_GROUP, 1, 1],
            "slice.comp" => [passes::slice::GROUP, passes::slice::GROUP, 1],
            "bricks.comp" | "superbricks.comp" => [consts::BRICKS_GROUP; 3],
            "test/layout_probe.comp" => [1, 1, 1],
            p if p.starts_with("extract/") => [passes::extract::GROUP, 1, 1],
            p if p.starts_with("occupancy/") => [passes::occupancy::GROUP, 1, 1],
            p => panic!("{p}: no expected workgroup size; add it here"),
        };
        assert_eq!(parse(spv).local_size, Some(want), "{path}");
    }
    assert_eq!(passes::extract::SCAN_BLOCK, u64::from(passes::extract::GROUP * consts::SCAN_PER));
    assert_eq!(passes::bricks::BRICK, consts::BRICK as usize);
}
