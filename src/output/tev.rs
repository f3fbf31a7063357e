//! Pushing a frame to the tev HDR viewer over its TCP remote-control protocol (tev listens on
//! 127.0.0.1:14158 by default). Written from the protocol's published description (tev's
//! `Ipc.h`: packet types and field order); no tev code is used.
//!
//! ```text
//!   packet       = u32 LE length of the whole packet (these 4 bytes included), u8 type, payload
//!   string       = UTF-8 bytes, then a NUL
//!   CreateImage  (type 4) = u8 grab_focus, string name, i32 width, i32 height,
//!                           i32 channel count, string channel name * count
//!   UpdateImage3 (type 6) = u8 grab_focus, string name, i32 channel count,
//!                           string channel name * count, i32 x, i32 y, i32 width, i32 height,
//!                           i64 offset * count, i64 stride * count, f32 data...
//!                           (channel c at pixel p of the rectangle: data[offset[c] + p * stride[c]])
//! ```
//!
//! All integers and floats little-endian. A frame goes as one CreateImage with every channel
//! the EXR would hold ([`super::exr::written_channels`]), then one UpdateImage per band of
//! [`TEV_BAND_ROWS`] rows, the channels interleaved (offset c, stride = channel count).

use std::io::Write;
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

use crate::frame::{Channel, Frame, Pixel};
use crate::vocab::echo;

/// Where tev listens unless told otherwise.
pub const DEFAULT_ADDRESS: &str = "127.0.0.1:14158";

/// Rows per UpdateImage packet.
pub const TEV_BAND_ROWS: u32 = 64;

/// Packet type of CreateImage.
pub const CREATE_IMAGE: u8 = 4;
/// Packet type of UpdateImage, version 3.
pub const UPDATE_IMAGE_V3: u8 = 6;

/// Why a frame could not be sent (one line, naming the address).
#[derive(Debug, thiserror::Error)]
pub enum TevError {
    // The address is the user's text (`--tev`, serve's page): echoed cut and escaped.
    #[error("tev at {}: {what}: {source} (is tev running and listening there?)", echo(address))]
    Io {
        address: String,
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error("tev at {}: the address does not resolve", echo(address))]
    Address { address: String },
    #[error("tev: {0}")]
    TooLarge(String),
}

/// A packet under construction: the length is patched in by [`Packet::finish`].
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Self {
        let mut bytes = vec![0; 4];
        bytes.push(kind);
        Packet(bytes)
    }
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn i32(&mut self, v: i32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn i64(&mut self, v: i64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn string(&mut self, s: &str) {
        // A NUL inside would end the string early on tev's side: cut it there.
        let s = s.split('\0').next().unwrap_or("");
        self.0.extend_from_slice(s.as_bytes());
        self.0.push(0);
    }
    fn finish(mut self) -> Result<Vec<u8>, TevError> {
        let len = u32::try_from(self.0.len()).map_err(|_| {
            TevError::TooLarge(format!("a packet of {} bytes is over 4 GiB", self.0.len()))
        })?;
        self.0[..4].copy_from_slice(&len.to_le_bytes());
        Ok(self.0)
    }
}

/// Converts an image side to the protocol's i32.
fn side(v: u32) -> Result<i32, TevError> {
    i32::try_from(v).map_err(|_| TevError::TooLarge(format!("{v} pixels do not fit an i32")))
}

/// The CreateImage packet of a `width` × `height` image with `channels`.
pub fn create_image(
    grab_focus: bool,
    name: &str,
    width: u32,
    height: u32,
    channels: &[&str],
) -> Result<Vec<u8>, TevError> {
    let mut p = Packet::new(CREATE_IMAGE);
    p.u8(grab_focus as u8);
    p.string(name);
    p.i32(side(width)?);
    p.i32(side(height)?);
    p.i32(channels.len() as i32);
    for c in channels {
        p.string(c);
    }
    p.finish()
}

/// The UpdateImage (v3) packet of rows `y .. y + rows` of `frame`'s `channels`, interleaved.
pub fn update_image(
    grab_focus: bool,
    name: &str,
    frame: &Frame,
    channels: &[Channel],
    y: u32,
    rows: u32,
) -> Result<Vec<u8>, TevError> {
    let start = y as usize * frame.width as usize;
    let end = (y + rows) as usize * frame.width as usize;
    rows_packet(grab_focus, name, frame.width, channels, y, &frame.pixels[start..end])
}

/// The UpdateImage (v3) packet of whole rows starting at row `y` of an image `width` wide:
/// `pixels` holds them, row after row.
pub fn rows_packet(
    grab_focus: bool,
    name: &str,
    width: u32,
    channels: &[Channel],
    y: u32,
    pixels: &[Pixel],
) -> Result<Vec<u8>, TevError> {
    let rows = (pixels.len() / width.max(1) as usize) as u32;
    let n = channels.len();
    let mut p = Packet::new(UPDATE_IMAGE_V3);
    p.u8(grab_focus as u8);
    p.string(name);
    p.i32(n as i32);
    for c in channels {
        p.string(c.name());
    }
    for v in [0, side(y)?, side(width)?, side(rows)?] {
        p.i32(v);
    }
    for c in 0..n {
        p.i64(c as i64);
    }
    for _ in 0..n {
        p.i64(n as i64);
    }
    for px in pixels {
        for c in channels {
            p.f32(c.get(px));
        }
    }
    p.finish()
}

/// Every packet that shows `frame` in tev as image `name`: CreateImage, then one UpdateImage
/// per band of [`TEV_BAND_ROWS`] rows.
pub fn frame_packets(name: &str, frame: &Frame) -> Result<Vec<Vec<u8>>, TevError> {
    let channels = super::exr::written_channels(frame);
    let names: Vec<&str> = channels.iter().map(|c| c.name()).collect();
    let mut packets = vec![create_image(true, name, frame.width, frame.height, &names)?];
    let mut y = 0;
    while y < frame.height {
        let rows = TEV_BAND_ROWS.min(frame.height - y);
        packets.push(update_image(false, name, frame, &channels, y, rows)?);
        y += rows;
    }
    Ok(packets)
}

fn io_error(address: &str, what: &'static str) -> impl FnOnce(std::io::Error) -> TevError {
    let address = address.to_string();
    move |source| TevError::Io { address, what, source }
}

/// A connection to tev at `address` (`HOST:PORT`), with the timeouts every send uses.
fn connect(address: &str) -> Result<TcpStream, TevError> {
    let target = address
        .to_socket_addrs()
        .map_err(io_error(address, "cannot resolve"))?
        .next()
        .ok_or_else(|| TevError::Address { address: address.to_string() })?;
    let stream = TcpStream::connect_timeout(&target, Duration::from_secs(2))
        .map_err(io_error(address, "cannot connect"))?;
    stream
        .set_write_timeout(Some(Duration::from_secs(10)))
        .map_err(io_error(address, "cannot connect"))?;
    Ok(stream)
}

/// Connects to tev at `address` (`HOST:PORT`) and sends `frame` as image `name`.
pub fn send_frame(address: &str, name: &str, frame: &Frame) -> Result<(), TevError> {
    let packets = frame_packets(name, frame)?;
    let mut stream = connect(address)?;
    for p in &packets {
        stream.write_all(p).map_err(io_error(address, "cannot send"))?;
    }
    stream.flush().map_err(io_error(address, "cannot send"))
}

/// An image shown in tev while it is rendered: CreateImage when opened, then the rows of each
/// band as the band finishes ([`TevImage::send_rows`], in UpdateImage packets of at most
/// [`TEV_BAND_ROWS`] rows), so tev fills the picture in as pbrt's display server does.
pub struct TevImage {
    stream: TcpStream,
    address: String,
    name: String,
    width: u32,
    channels: Vec<Channel>,
}

impl TevImage {
    /// Connects and creates image `name`, `width` × `height`, with `channels`.
    pub fn open(
        address: &str,
        name: &str,
        width: u32,
        height: u32,
        channels: Vec<Channel>,
    ) -> Result<TevImage, TevError> {
        let mut stream = connect(address)?;
        let names: Vec<&str> = channels.iter().map(|c| c.name()).collect();
        let packet = create_image(true, name, width, height, &names)?;
        stream.write_all(&packet).map_err(io_error(address, "cannot send"))?;
        let (address, name) = (address.to_string(), name.to_string());
        Ok(TevImage { stream, address, name, width, channels })
    }

    /// Sends whole rows from row `y` on (`pixels`, row after row).
    pub fn send_rows(&mut self, y: u32, pixels: &[Pixel]) -> Result<(), TevError> {
        let per_packet = TEV_BAND_ROWS as usize * self.width as usize;
        for (n, chunk) in pixels.chunks(per_packet.max(1)).enumerate() {
            let row = y + n as u32 * TEV_BAND_ROWS;
            let packet = rows_packet(false, &self.name, self.width, &self.channels, row, chunk)?;
            self.stream.write_all(&packet).map_err(io_error(&self.address, "cannot send"))?;
        }
        self.stream.flush().map_err(io_error(&self.address, "cannot send"))
    }
}
