//! The shared vocabulary of the pipeline: plain types that the scene, the field sources, the
//! mesh extractors and the passes all speak. It depends on nothing else in the crate, so every
//! module may use it without creating a cycle (docs/contributing.md "Layout"); `scene` re-exports it.

use glam::DVec3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inside {
    /// Values below the isovalue are inside (signed distance fields).
    Below,
    /// Values above the isovalue are inside.
    Above,
}

impl Inside {
    /// Both conventions.
    pub const ALL: [Inside; 2] = [Inside::Below, Inside::Above];

    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Inside::Below => "below",
            Inside::Above => "above",
        }
    }

    /// The one inside test every method follows (GPU: `is_inside` in `shaders/include/field.glsl`):
    /// strictly below (or above) the isovalue is inside; a value equal to the isovalue is
    /// outside. A crossing is a change of this predicate between two points.
    pub fn contains(self, value: f64, isovalue: f64) -> bool {
        match self {
            Inside::Below => value < isovalue,
            Inside::Above => value > isovalue,
        }
    }
}

/// `render.hermite`: where the sharp-feature meshes take each crossed edge's crossing and
/// normal from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HermiteNormals {
    /// The crossing of the samples' linear interpolation along the edge (as every method) and
    /// the gradient of the trilinear interpolant there: works for any source.
    Trilinear,
    /// The source itself (sources that can be evaluated anywhere: `sdf`, `expr`, `corners`,
    /// `mesh`): the crossing found on the source along the edge, the normal from the source's
    /// central-difference gradient there. Recovers features the samples only blur.
    Source,
}

impl HermiteNormals {
    pub const ALL: [HermiteNormals; 2] = [HermiteNormals::Trilinear, HermiteNormals::Source];

    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            HermiteNormals::Trilinear => "trilinear",
            HermiteNormals::Source => "source",
        }
    }
}

/// The settings of the sharp-feature and adaptive meshes (`render.hermite`, `qef_threshold`,
/// `qef_clamp`, `feature_angle`, `mesh_error`); defaults in [`SharpSettings::default`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SharpSettings {
    pub hermite: HermiteNormals,
    /// QEF solve: singular values below this fraction of the largest are dropped (the
    /// pseudo-inverse's threshold), so the vertex moves towards the crossings' mean along
    /// directions the planes do not pin down. In `(0, 1)`.
    pub qef_threshold: f64,
    /// QEF solve: clamp the vertex into its cell (else it may leave the cell where planes
    /// are nearly parallel but not quite).
    pub qef_clamp: bool,
    /// Extended MC: a cell's surface piece is a feature when two of its crossings' normals
    /// are further apart than this angle, in degrees.
    pub feature_angle_deg: f64,
    /// Dual contouring QEF: `Some(ε)` builds an octree and collapses cells whose vertex stays
    /// within ε (world units) of every tangent plane below it (adaptive); None: uniform.
    pub mesh_error: Option<f64>,
}

impl Default for SharpSettings {
    /// Trilinear Hermite data, threshold 0.1 (Ju et al.'s value), clamped, 30°, uniform.
    fn default() -> Self {
        SharpSettings {
            hermite: HermiteNormals::Trilinear,
            qef_threshold: 0.1,
            qef_clamp: true,
            feature_angle_deg: 30.0,
            mesh_error: None,
        }
    }
}

/// Axis-aligned world-space box of the grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl Bounds {
    /// The unit cube `[0, 1]^3`.
    pub const UNIT: Bounds = Bounds { min: DVec3::ZERO, max: DVec3::ONE };

    /// The grid's own index space, `[0, 0, 0]..[nx - 1, ny - 1, nz - 1]`: the default when a
    /// scene gives no `bounds` (for one cell, the unit cube).
    pub fn index_space(resolution: [usize; 3]) -> Bounds {
        let [nx, ny, nz] = resolution.map(|n| n.saturating_sub(1) as f64);
        Bounds { min: DVec3::ZERO, max: DVec3::new(nx, ny, nz) }
    }
}

/// Signed-distance shapes of `source = "sdf"`; `center` is subtracted before evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SdfShape {
    Sphere { radius: f64 },
    Box { half_extents: DVec3 },
    Torus { major_radius: f64, minor_radius: f64 },
    Gyroid { scale: f64, thickness: f64 },
}

/// Where the grid sits in world space when its axes are not the world's: a rigid map (a
/// rotation, possibly with a reflection) about `pivot`, the world position of point (0, 0, 0).
///
/// Every method works in the grid's own frame, where the grid is the axis-aligned box of its
/// `Bounds` (origin plus spacing times index); `world = pivot + axes * (p - pivot)`. A scan's
/// header (NIfTI sform/qform, NRRD `space directions`, MetaImage `TransformMatrix`) gives the
/// axes; spacing stays in the box, so `axes` is orthonormal and distances, angles and hence
/// depths, shading and step counts are the same in both frames: only positions and normals
/// move (docs/formats.md "Physical space"). Sheared axes are refused where a reader builds the
/// placement ([`Placement::from_axes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub pivot: DVec3,
    /// Columns: the world directions of the grid's x, y and z axes (unit, orthogonal).
    pub axes: glam::DMat3,
}

impl Placement {
    /// The grid's axes are the world's.
    pub const IDENTITY: Placement = Placement { pivot: DVec3::ZERO, axes: glam::DMat3::IDENTITY };

    /// How far from orthonormal a header's axes may be (dot products, lengths) before they are
    /// called sheared: headers store direction cosines in f32 or as decimal text.
    pub const ORTHO_TOLERANCE: f64 = 1e-4;

    /// A placement from a header's axis directions (any lengths: they are normalised), or why
    /// not: axes that are parallel, or not orthogonal within [`Placement::ORTHO_TOLERANCE`].
    /// Nearly orthogonal axes are made exactly orthonormal (Gram-Schmidt, handedness kept).
    pub fn from_axes(pivot: DVec3, axes: [DVec3; 3]) -> Result<Placement, String> {
        let mut u = [DVec3::ZERO; 3];
        for (k, a) in axes.iter().enumerate() {
            let len = a.length();
            if !len.is_finite() || len == 0.0 {
                return Err(format!("axis {} has no direction ({a})", "xyz".as_bytes()[k] as char));
            }
            u[k] = *a / len;
        }
        for (a, b) in [(0, 1), (0, 2), (1, 2)] {
            let d = u[a].dot(u[b]);
            if d.abs() > Self::ORTHO_TOLERANCE {
                return Err(format!(
                    "the grid's axes are sheared (axes {} and {} meet at {:.4} degrees); \
                     set [field] bounds to place it axis-aligned",
                    "xyz".as_bytes()[a] as char,
                    "xyz".as_bytes()[b] as char,
                    d.clamp(-1.0, 1.0).acos().to_degrees()
                ));
            }
        }
        let x = u[0];
        let y = (u[1] - x * x.dot(u[1])).normalize();
        let mut z = x.cross(y);
        if z.dot(u[2]) < 0.0 {
            z = -z; // a reflection: keep the header's handedness
        }
        let axes = glam::DMat3::from_cols(x, y, z);
        Ok(Placement { pivot, axes })
    }

    /// Whether this is the identity (nothing to transform: the output is exactly as before).
    pub fn is_identity(&self) -> bool {
        self.axes == glam::DMat3::IDENTITY
    }

    /// Whether the axes are a reflection (a mesh's triangle winding must then be reversed to
    /// keep its normals pointing out).
    pub fn mirrors(&self) -> bool {
        self.axes.determinant() < 0.0
    }

    /// A point of the grid's frame in world space.
    pub fn point_to_world(&self, p: DVec3) -> DVec3 {
        if self.is_identity() {
            return p;
        }
        self.pivot + self.axes * (p - self.pivot)
    }

    /// A world point in the grid's frame.
    pub fn point_to_grid(&self, p: DVec3) -> DVec3 {
        if self.is_identity() {
            return p;
        }
        self.pivot + self.axes.transpose() * (p - self.pivot)
    }

    /// A direction or normal of the grid's frame in world space (the axes are orthonormal, so
    /// normals transform like directions).
    pub fn vector_to_world(&self, v: DVec3) -> DVec3 {
        self.axes * v
    }

    /// A world direction in the grid's frame.
    pub fn vector_to_grid(&self, v: DVec3) -> DVec3 {
        self.axes.transpose() * v
    }
}

impl Default for Placement {
    fn default() -> Self {
        Placement::IDENTITY
    }
}

/// Clip planes (`[[clip]]` in a scene): each removes the half-space where
/// `dot(normal, p) > offset`; what survives is their intersection, a convex region, so a ray
/// keeps one interval of `t` ([`Clip::interval`]; GPU: `clip_interval` in
/// `shaders/include/field.glsl`). A clip box is its six faces. Points exactly on a plane are
/// kept. Fixed capacity, so it is `Copy` and fits the shaders' uniform block.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Clip {
    /// `(normal, offset)` per plane; only the first `count` are used.
    pub planes: [(DVec3, f64); Clip::MAX_PLANES],
    pub count: usize,
}

impl Clip {
    /// Planes one scene may use (a box takes six).
    pub const MAX_PLANES: usize = 12;

    /// No clipping.
    pub const NONE: Clip = Clip { planes: [(DVec3::ZERO, 0.0); Clip::MAX_PLANES], count: 0 };

    /// The planes in use.
    pub fn planes(&self) -> &[(DVec3, f64)] {
        &self.planes[..self.count]
    }

    /// Adds a plane; false when all [`Clip::MAX_PLANES`] are taken.
    pub fn push(&mut self, normal: DVec3, offset: f64) -> bool {
        if self.count == Clip::MAX_PLANES {
            return false;
        }
        self.planes[self.count] = (normal, offset);
        self.count += 1;
        true
    }

    /// The `t` interval of the ray `origin + t dir` that every plane keeps (unbounded ends as
    /// infinities), or None when the ray lies wholly in a removed half-space.
    pub fn interval(&self, origin: DVec3, dir: DVec3) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for &(n, offset) in self.planes() {
            let s = n.dot(dir);
            let v = n.dot(origin) - offset;
            if s == 0.0 {
                if v > 0.0 {
                    return None;
                }
                continue;
            }
            let t = -v / s;
            if s > 0.0 {
                hi = hi.min(t);
            } else {
                lo = lo.max(t);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// The same planes in the grid's own frame (`world = pivot + axes (p - pivot)`).
    pub fn in_grid_frame(&self, placement: &Placement) -> Clip {
        if placement.is_identity() {
            return *self;
        }
        let mut out = *self;
        for (n, offset) in out.planes[..self.count].iter_mut() {
            let ng = placement.vector_to_grid(*n);
            *offset = *offset - n.dot(placement.pivot) + ng.dot(placement.pivot);
            *n = ng;
        }
        out
    }
}

/// How a message quotes a value the user wrote (a `--set`, an argument, a scene value):
/// control characters escaped (`\n`, `\u{1b}`: a message stays one line and cannot drive
/// the terminal) and, past [`ECHO_CHARS`] characters, cut with `…` (a 10 MB value does not
/// become a 10 MB message). Every message that repeats a user's value passes it through here.
pub fn echo(value: &str) -> String {
    escape_unprintable(&echo_cut(value)).into_owned()
}

/// Whether a message shows `c` escaped rather than as itself: control characters (a newline
/// splits the line, ESC starts a terminal sequence) and the bidirectional embeddings,
/// overrides, isolates and marks (U+202E reverses what follows on a terminal, so a file
/// name could read as another).
pub fn is_unprintable(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{200e}' | '\u{200f}' | '\u{061c}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// `text` with each [`is_unprintable`] character escaped (`\n`, `\u{1b}`, `\u{202e}`), not
/// cut: [`echo`]'s escaping, and what every `isoview: ...` line on stderr passes through
/// (`cli::console::note_line`), so a path or value printed raw somewhere still cannot split
/// the line or drive the terminal.
pub fn escape_unprintable(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(is_unprintable) {
        return text.into();
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if is_unprintable(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out.into()
}

/// A whole message as it is printed (every `isoview:` line on stderr, `serve`'s error
/// replies): [`escape_unprintable`], and past [`MESSAGE_CHARS`] characters its middle cut, the
/// first [`MESSAGE_HEAD`] and last [`MESSAGE_TAIL`] kept around `… (N characters cut) …`.
/// Values are cut by [`echo`] where they are quoted, but paths are shown whole (a path cut to
/// 60 characters would not say which file), and a scene can name a 2 MB path, which the OS
/// refuses as too long: its message was 2 MB. The cut keeps the start (the file, line and key)
/// and the end (the cause), and never touches a message naming a few legal paths (the OS
/// opens none over 4,096 bytes).
pub fn message_line(text: &str) -> std::borrow::Cow<'_, str> {
    let escaped = escape_unprintable(text);
    let count = escaped.chars().count();
    if count <= MESSAGE_CHARS {
        return escaped;
    }
    let head_end = escaped.char_indices().nth(MESSAGE_HEAD).map_or(escaped.len(), |(at, _)| at);
    let tail_start =
        escaped.char_indices().nth(count - MESSAGE_TAIL).map_or(escaped.len(), |(at, _)| at);
    let cut = count - MESSAGE_HEAD - MESSAGE_TAIL;
    format!("{} … ({cut} characters cut) … {}", &escaped[..head_end], &escaped[tail_start..]).into()
}

/// The longest message [`message_line`] prints whole, in characters.
pub const MESSAGE_CHARS: usize = 16_384;
/// How many characters of a longer message's start [`message_line`] keeps.
pub const MESSAGE_HEAD: usize = 8_192;
/// How many characters of a longer message's end [`message_line`] keeps.
pub const MESSAGE_TAIL: usize = 2_048;

/// [`echo`]'s cut alone (the first [`ECHO_CHARS`] characters, then `…`), for a message that
/// escapes the value itself (a `{:?}` in another crate's error: `isoview-gpu`'s device name).
pub fn echo_cut(value: &str) -> std::borrow::Cow<'_, str> {
    match value.char_indices().nth(ECHO_CHARS) {
        Some((at, _)) => format!("{}…", &value[..at]).into(),
        None => value.into(),
    }
}

/// How many characters of a user's value [`echo`] keeps.
pub const ECHO_CHARS: usize = 60;

/// How a message quotes a number the user gave (a flag such as `--at`, already parsed), the
/// [`echo`] of numbers: Rust writes `1e308` as 309 digits and `1e-300` as 302 characters, so
/// a long plain form becomes the shortest exponent form that reads back as the same number
/// (`1e308`, `-1.5e-300`), usually what the user typed. Cutting the digits as [`echo`] cuts
/// text would change the number.
pub fn echo_number<T: std::fmt::Display + std::fmt::LowerExp>(value: T) -> String {
    let plain = value.to_string();
    if plain.len() <= ECHO_NUMBER_CHARS {
        plain
    } else {
        format!("{value:e}")
    }
}

/// The longest plain form [`echo_number`] keeps (`0.30000000000000004` is 19 characters).
const ECHO_NUMBER_CHARS: usize = 24;

/// Opens an input (`noun`: "a data file", "an EXR file") for reading, refusing a path that is
/// not a regular file (a FIFO, a device, a socket, a folder) with [`NotRegular`].
///
/// The open itself must not wait: opening a FIFO for reading blocks until a writer comes
/// (it hung the command line and wedged `serve` workers). So the file is opened non-blocking
/// and judged by `fstat` on what was opened (no window for a swap between a check and the
/// open). O_NONBLOCK has no effect on reading a regular file, so it stays set.
pub fn open_regular(path: &std::path::Path, noun: &'static str) -> std::io::Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    let file = std::fs::OpenOptions::new().read(true).custom_flags(libc::O_NONBLOCK).open(path)?;
    match special_file(&file.metadata()?) {
        None => Ok(file),
        Some(kind) => Err(std::io::Error::other(NotRegular { kind, noun })),
    }
}

/// What [`open_regular`] refuses: `is a FIFO (named pipe), not a data file`.
#[derive(Debug)]
pub struct NotRegular {
    pub kind: &'static str,
    pub noun: &'static str,
}

impl std::fmt::Display for NotRegular {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.kind {
            // As a read of a folder has always been worded.
            "a directory" => write!(f, "is a directory, not a file"),
            kind => write!(f, "is {kind}, not {}", self.noun),
        }
    }
}

impl std::error::Error for NotRegular {}

/// What a file that is not a regular file is, for messages ("a FIFO (named pipe)", "a
/// directory"); None for a regular file. Outputs (`output::guard`) and scene files
/// must be regular files.
pub fn special_file(meta: &std::fs::Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        return None;
    }
    if t.is_dir() {
        return Some("a directory");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if t.is_char_device() {
            return Some("a character device");
        }
        if t.is_block_device() {
            return Some("a block device");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some("a special file")
}

#[cfg(test)]
mod echo_tests {
    use super::*;

    #[test]
    fn echo_escapes_and_cuts() {
        assert_eq!(echo("render.steps=64"), "render.steps=64");
        assert_eq!(echo("a\nb\r\tc\u{1b}[2J"), "a\\nb\\r\\tc\\u{1b}[2J");
        let long = "x".repeat(10_000_000);
        let e = echo(&long);
        assert_eq!(e, format!("{}…", "x".repeat(ECHO_CHARS)));
        assert_eq!(echo(&"é".repeat(ECHO_CHARS)), "é".repeat(ECHO_CHARS));
    }

    #[test]
    fn message_line_cuts_the_middle_of_a_long_message_only() {
        let short = format!("s.toml:15:8: field.path: {}: cannot read", "a/".repeat(2048));
        assert_eq!(message_line(&short), short);
        assert_eq!(message_line("a\nb"), "a\\nb");
        let long = format!(
            "s.toml:15:8: field.path: {}x.npy: cannot read: too long",
            "a/".repeat(1_000_000)
        );
        let line = message_line(&long);
        assert!(line.starts_with("s.toml:15:8: field.path: a/a/"), "{}", &line[..40]);
        assert!(line.ends_with("a/x.npy: cannot read: too long"));
        let cut = long.chars().count() - MESSAGE_HEAD - MESSAGE_TAIL;
        assert!(line.contains(&format!(" … ({cut} characters cut) … ")));
        assert!(line.chars().count() < MESSAGE_CHARS + 40);
        // Characters, not bytes: a cut never splits one.
        let wide = "é".repeat(MESSAGE_CHARS + 1);
        assert_eq!(
            message_line(&wide).chars().filter(|&c| c == 'é').count(),
            MESSAGE_HEAD + MESSAGE_TAIL
        );
    }

    #[test]
    fn echo_number_keeps_numbers_short_and_exact() {
        for (v, shown) in [
            (1.5, "1.5"),
            (-0.25, "-0.25"),
            (0.1 + 0.2, "0.30000000000000004"),
            (1e20, "100000000000000000000"),
            (1e308, "1e308"),
            (-1e-300, "-1e-300"),
            (f64::MAX, "1.7976931348623157e308"),
            (f64::INFINITY, "inf"),
        ] {
            assert_eq!(echo_number(v), shown);
        }
        for v in [1e308, -2.5e-300, f64::MIN_POSITIVE, 1e100 / 3.0] {
            assert_eq!(echo_number(v).parse::<f64>(), Ok(v));
        }
        assert!(echo_number(f64::NAN) == "NaN");
    }
}
