//! What a render produces: one [`Pixel`] record per image pixel, the facts that say how it
//! was made, and the **channel table** ([`Channel`]) that says, once, what each output channel
//! is: its EXR name, its comparison class, its value on a miss, when it is written, and which
//! member of [`Pixel`] holds it. The EXR writer and reader (`output::exr`), `compare`'s
//! classes and the CPU references all read that table.
//!
//! `Pixel` is written by the compute shaders (`shaders/include/pixel.glsl`) and read back as
//! is, so its layout is fixed, asserted here and checked against the compiled shaders
//! (`tests/it/gpu/layout.rs`).
//!
//! # Adding a channel
//!
//! 1. a member of [`Pixel`] (here) and of `struct Pixel` in `shaders/include/pixel.glsl`;
//! 2. a row of the table below (name, class, miss value, when written, the `Pixel` member);
//! 3. the shaders' lines that fill it, and the CPU references' (`reference::shade::pixel`,
//!    a struct literal: a member it does not fill is a compile error).
//!
//! A `Pixel` member without a table row fails the size assertion below; a table row without
//! a member fails to compile; a GLSL struct that differs fails `layout::shared_structs_*`.

use std::fmt;

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use crate::vocab::Placement;

/// One pixel of every output channel (the EXR channels of the interface contract).
///
/// std430 layout, 80 bytes; mirrored by `struct Pixel` in `shaders/include/pixel.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Pixel {
    /// Shaded colour, linear; A is coverage (1 on a hit). The background on a miss.
    pub rgba: [f32; 4],
    /// World-space unit normal, inside to outside; 0 on a miss.
    pub normal: [f32; 3],
    /// Distance along the (unit) ray from the eye to the hit; +inf on a miss.
    pub depth: f32,
    /// World-space hit position; 0 on a miss.
    pub position: [f32; 3],
    /// Samples (fixed-step) or cells (analytic) the ray visited, hit or miss.
    pub steps: f32,
    /// Index of the grid cell that was hit; -1 on a miss.
    pub cell: [i32; 3],
    /// Number of isovalue crossings along the ray inside the box, where the method counts them
    /// (analytic); -1 where it does not.
    pub crossings: i32,
    /// Which surface was hit (its index in `surface.isovalues`), with several isovalues; -1 on
    /// a miss and everywhere with one isovalue (no channel).
    pub surface: i32,
    /// The quantity `[color] by` colours the surface with, at the hit; NaN on a miss and
    /// everywhere without `[color]` (no channel).
    pub value: f32,
    /// std430 pads the struct to a multiple of 16 bytes.
    pub pad: [u32; 2],
}

const _: () = {
    assert!(std::mem::size_of::<Pixel>() == 80);
    assert!(std::mem::offset_of!(Pixel, normal) == 16);
    assert!(std::mem::offset_of!(Pixel, depth) == 28);
    assert!(std::mem::offset_of!(Pixel, position) == 32);
    assert!(std::mem::offset_of!(Pixel, steps) == 44);
    assert!(std::mem::offset_of!(Pixel, cell) == 48);
    assert!(std::mem::offset_of!(Pixel, crossings) == 60);
    assert!(std::mem::offset_of!(Pixel, surface) == 64);
    assert!(std::mem::offset_of!(Pixel, value) == 68);
};

impl Pixel {
    /// The record of a ray that hit nothing, over `background`: every channel's [`Miss`]
    /// value from the table, `steps` as counted.
    pub fn miss(background: [f32; 4], steps: f32) -> Self {
        let mut p = Pixel::zeroed();
        for c in Channel::ALL {
            let v = match c.miss() {
                Miss::Background(i) => background[i],
                Miss::Value(v) => v,
                Miss::Counted => steps,
            };
            c.set(&mut p, v);
        }
        p
    }

    /// Whether the ray hit the surface.
    pub fn is_hit(&self) -> bool {
        self.depth.is_finite()
    }

    /// Moves a hit traced in the grid's own frame to world space: its position and normal
    /// (depth, colour, steps and cell do not change under a rigid placement). Misses and an
    /// identity placement are left exactly as they are.
    pub fn place(&mut self, placement: &Placement) {
        if placement.is_identity() || !self.is_hit() {
            return;
        }
        let p = placement.point_to_world(DVec3::from(self.position.map(f64::from)));
        let n = placement.vector_to_world(DVec3::from(self.normal.map(f64::from)));
        self.position = p.as_vec3().to_array();
        self.normal = n.as_vec3().to_array();
    }
}

/// The records of several surfaces' one-surface renders of the same rays (`layers`, in surface
/// order) combined, pixel by pixel, as one render of all of them: the nearest hit wins (ties:
/// the lower surface) with its `iso_index` set; `steps` and `crossings` are summed (for the
/// mesh method, whose every surface's triangles are tested; -1 stays "not counted").
pub fn composite_surfaces(layers: &[Vec<Pixel>]) -> Vec<Pixel> {
    let Some(first) = layers.first() else { return Vec::new() };
    (0..first.len())
        .map(|i| {
            let mut best: Option<(usize, Pixel)> = None;
            let (mut steps, mut crossings) = (0.0f32, 0i32);
            for (k, layer) in layers.iter().enumerate() {
                let p = layer[i];
                steps += p.steps;
                crossings =
                    if p.crossings < 0 || crossings < 0 { -1 } else { crossings + p.crossings };
                if p.is_hit() && best.as_ref().map_or(true, |(_, b)| p.depth < b.depth) {
                    best = Some((k, p));
                }
            }
            let mut out = match best {
                Some((k, p)) => Pixel { surface: k as i32, ..p },
                None => first[i],
            };
            out.steps = steps;
            out.crossings = crossings;
            out
        })
        .collect()
}

/// [`Pixel::place`] for every pixel.
pub fn place_pixels(pixels: &mut [Pixel], placement: &Placement) {
    if !placement.is_identity() {
        pixels.iter_mut().for_each(|p| p.place(placement));
    }
}

/// The kind of quantity a channel holds, which picks `compare`'s thresholds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ChannelClass {
    /// `R`, `G`, `B`, `A` (also in a layer: `beauty.R`).
    Colour,
    /// `Z`, `ZBack` (also `depth.Z`).
    Depth,
    /// `N.*`, `normal.*`, `Normal.*`.
    Normal,
    /// `P.*`, `position.*`, `Position.*`.
    Position,
    /// `steps`, `crossings`, `iso_index`, `cell.*`, and every UINT channel: exact by default.
    Integer,
    /// Anything else.
    Other,
}

impl ChannelClass {
    pub const ALL: [ChannelClass; 6] = [
        ChannelClass::Colour,
        ChannelClass::Depth,
        ChannelClass::Normal,
        ChannelClass::Position,
        ChannelClass::Integer,
        ChannelClass::Other,
    ];

    /// The name used on the command line (`--fail-class depth=1e-3`).
    pub fn name(self) -> &'static str {
        match self {
            ChannelClass::Colour => "colour",
            ChannelClass::Depth => "depth",
            ChannelClass::Normal => "normal",
            ChannelClass::Position => "position",
            ChannelClass::Integer => "integer",
            ChannelClass::Other => "other",
        }
    }

    /// Parses a class name (`color` is accepted for `colour`).
    pub fn parse(s: &str) -> Option<ChannelClass> {
        match s {
            "color" => Some(ChannelClass::Colour),
            _ => ChannelClass::ALL.into_iter().find(|c| c.name() == s),
        }
    }
}

impl fmt::Display for ChannelClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A channel's value where the ray hit nothing ([`Pixel::miss`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Miss {
    /// Component `i` of `render.background` (R, G, B, A).
    Background(usize),
    /// This value.
    Value(f32),
    /// Counted anyway (the work the ray did).
    Counted,
}

/// When the EXR writer includes a channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Written {
    /// In every file.
    Always,
    /// Only when some pixel holds a count (a value >= 0); -1 means "not counted", and a file
    /// without the channel reads back as -1 everywhere.
    WhereCounted,
    /// Only when some pixel holds a finite value; NaN means "no value", and a file without
    /// the channel reads back as NaN everywhere.
    WhereFinite,
}

/// How a `Pixel` member's type converts to and from the EXR's 32-bit float samples.
trait Sample: Copy {
    fn to_f32(self) -> f32;
    fn from_f32(v: f32) -> Self;
}

impl Sample for f32 {
    fn to_f32(self) -> f32 {
        self
    }
    fn from_f32(v: f32) -> Self {
        v
    }
}

impl Sample for i32 {
    fn to_f32(self) -> f32 {
        self as f32
    }
    fn from_f32(v: f32) -> Self {
        v as i32
    }
}

/// Declares [`Channel`] from the table: one row per channel, every property in the row, so a
/// row cannot leave one out and no property is written anywhere else.
macro_rules! channel_table {
    ($(
        $(#[doc = $doc:literal])*
        $variant:ident = $name:literal, $class:ident, $miss:expr, $written:ident,
            $member:ident $([$i:literal])?;
    )+) => {
        /// One output channel of a render (the rows of the EXR table in docs/formats.md).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Channel {
            $($(#[doc = $doc])* $variant,)+
        }

        impl Channel {
            /// Every channel, in the order of the [`Pixel`] members (files store them sorted
            /// by name).
            pub const ALL: [Channel; [$($name),+].len()] = [$(Channel::$variant),+];

            /// The EXR channel name.
            pub const fn name(self) -> &'static str {
                match self { $(Channel::$variant => $name,)+ }
            }

            /// What kind of quantity it holds (picks `compare`'s thresholds).
            pub const fn class(self) -> ChannelClass {
                match self { $(Channel::$variant => ChannelClass::$class,)+ }
            }

            /// Its value on a miss.
            pub const fn miss(self) -> Miss {
                use Miss::*;
                match self { $(Channel::$variant => $miss,)+ }
            }

            /// When the EXR writer includes it.
            pub const fn written(self) -> Written {
                match self { $(Channel::$variant => Written::$written,)+ }
            }

            /// Its value in `p`, as the EXR stores it (32-bit float).
            pub fn get(self, p: &Pixel) -> f32 {
                match self { $(Channel::$variant => Sample::to_f32(p.$member $([$i])?),)+ }
            }

            /// Sets its member of `p` from the EXR's float value.
            pub fn set(self, p: &mut Pixel, v: f32) {
                match self { $(Channel::$variant => p.$member $([$i])? = Sample::from_f32(v),)+ }
            }
        }
    };
}

channel_table! {
    /// Shaded colour, linear Rec.709.
    R = "R", Colour, Background(0), Always, rgba[0];
    G = "G", Colour, Background(1), Always, rgba[1];
    B = "B", Colour, Background(2), Always, rgba[2];
    /// Coverage: 1 on a hit.
    A = "A", Colour, Background(3), Always, rgba[3];
    /// World-space unit normal, inside to outside.
    NX = "N.X", Normal, Value(0.0), Always, normal[0];
    NY = "N.Y", Normal, Value(0.0), Always, normal[1];
    NZ = "N.Z", Normal, Value(0.0), Always, normal[2];
    /// Distance along the ray from the eye to the hit.
    Z = "Z", Depth, Value(f32::INFINITY), Always, depth;
    /// World-space hit position.
    PX = "P.X", Position, Value(0.0), Always, position[0];
    PY = "P.Y", Position, Value(0.0), Always, position[1];
    PZ = "P.Z", Position, Value(0.0), Always, position[2];
    /// Samples (fixed-step), cells (analytic) or triangles (mesh) visited.
    Steps = "steps", Integer, Counted, Always, steps;
    /// Index of the grid cell hit.
    CellX = "cell.X", Integer, Value(-1.0), Always, cell[0];
    CellY = "cell.Y", Integer, Value(-1.0), Always, cell[1];
    CellZ = "cell.Z", Integer, Value(-1.0), Always, cell[2];
    /// Isovalue crossings along the ray, where the method counts them.
    Crossings = "crossings", Integer, Value(-1.0), WhereCounted, crossings;
    /// Index of the surface hit (`surface.isovalues`), with several isovalues.
    Surface = "iso_index", Integer, Value(-1.0), WhereCounted, surface;
    /// The value `[color] by` maps through the colormap, at the hit.
    ColorValue = "color.value", Other, Value(f32::NAN), WhereFinite, value;
}

// Every member of `Pixel` but the padding is one 4-byte channel: a member without a table row
// fails here.
const _: () = assert!(
    Channel::ALL.len() * 4 + std::mem::size_of::<[u32; 2]>() == std::mem::size_of::<Pixel>()
);

impl Channel {
    /// The channel named `name` (as written in the EXR).
    pub fn from_name(name: &str) -> Option<Channel> {
        Channel::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// A rendered image: `width * height` pixels, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Pixel>,
    /// How the frame was made, for the output headers.
    pub info: FrameInfo,
}

impl Frame {
    /// The pixel at column `x`, row `y` (0 = top).
    pub fn pixel(&self, x: u32, y: u32) -> &Pixel {
        &self.pixels[(y * self.width + x) as usize]
    }
}

/// Provenance of a frame, written into the EXR header so that a file alone says how it was made.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameInfo {
    /// The scene file, as given on the command line (empty for scenes built in code).
    pub scene: String,
    pub eye: DVec3,
    pub target: DVec3,
    pub up: DVec3,
    pub fov_y_deg: f64,
    /// The view's height in world units for an orthographic camera; None: perspective.
    pub ortho_height: Option<f64>,
    pub isovalue: f64,
    /// `render.method` as written in scenes (`analytic`, `fixed-step`, `mesh`).
    pub method: String,
    /// Time of the field (`--time`), 0 when not time-varying.
    pub time: f64,
    /// Vulkan device name and driver string the frame was rendered on.
    pub device: String,
    pub driver: String,
    /// Further `key = value` facts (method parameters, colormap scales).
    pub extra: Vec<(String, String)>,
    /// The colour bar of `[color] by` (the PNG preview draws it).
    pub legend: Option<Legend>,
}

/// What the colour bar of a `[color] by` picture shows: the colormap and the values at its
/// ends (`render::color` makes it; the PNG preview draws it).
#[derive(Clone, Debug, PartialEq)]
pub struct Legend {
    /// `[color] by`, for the label.
    pub by: &'static str,
    pub colormap: &'static str,
    pub lo: f64,
    pub hi: f64,
    /// 256 linear RGB entries.
    pub lut: Vec<[f32; 3]>,
}
