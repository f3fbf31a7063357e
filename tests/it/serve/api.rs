//! `isoview serve` from the outside: the binary on port 0, plain HTTP/1.0 over a TcpStream.
//! What the server answers must be what the command line makes of the same state, bit for
//! bit (lavapipe is deterministic): frames = `render --png`, EXRs = `render -o`, probes =
//! `probe --json`, bad overrides = the CLI's one-line message. Also: the token and Host
//! checks, stale states dropped, the coarse frame's pixels, and tev's wire format, decoded by
//! a parser written here from the protocol's description (not from isoview's encoder).

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use crate::common::{isoview, scratch, stderr};

pub(crate) fn scene(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name).display().to_string()
}

/// A running `isoview serve`, killed when dropped.
pub(crate) struct Server {
    pub(crate) child: Child,
    /// `127.0.0.1:PORT`
    pub(crate) addr: String,
    pub(crate) token: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// An HTTP answer.
pub(crate) struct Answer {
    pub(crate) status: u16,
    headers: HashMap<String, String>,
    pub(crate) body: Vec<u8>,
}

impl Answer {
    pub(crate) fn header(&self, name: &str) -> &str {
        self.headers.get(&name.to_ascii_lowercase()).map_or("", String::as_str)
    }
    pub(crate) fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }
    pub(crate) fn json(&self) -> serde_json::Value {
        serde_json::from_slice(&self.body).unwrap_or_else(|e| panic!("{e}: {}", self.text()))
    }
}

impl Server {
    pub(crate) fn start(scene_file: &str, args: &[&str]) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_isoview"))
            .args(["serve", scene_file, "--port", "0"])
            .args(args)
            .env_remove("ISOVIEW_DEVICE")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start isoview serve");
        let stdout = child.stdout.take().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let _ = BufReader::new(stdout).read_line(&mut line);
            let _ = tx.send(line);
        });
        let line = match rx.recv_timeout(Duration::from_secs(120)) {
            Ok(l) => l,
            Err(_) => {
                let _ = child.kill();
                panic!("isoview serve printed no URL within 120 s");
            }
        };
        let mut server = Server { child, addr: String::new(), token: String::new() };
        let url = line.trim();
        let rest = url.strip_prefix("http://").unwrap_or_else(|| panic!("first line: {url}"));
        let (addr, token) =
            rest.split_once("/?token=").unwrap_or_else(|| panic!("first line: {url}"));
        assert!(addr.starts_with("127.0.0.1:"), "binds loopback by default: {url}");
        assert_eq!(token.len(), 32, "{url}");
        server.addr = addr.to_string();
        server.token = token.to_string();
        server
    }

    /// Sends one request (HTTP/1.0: one answer, then the server closes).
    pub(crate) fn raw(
        &self,
        method: &str,
        path: &str,
        headers: &[(&str, &str)],
        body: &[u8],
    ) -> Answer {
        let mut s = TcpStream::connect(&self.addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(180))).unwrap();
        let mut req = format!("{method} {path} HTTP/1.0\r\nContent-Length: {}\r\n", body.len());
        if !headers.iter().any(|(k, _)| k.eq_ignore_ascii_case("host")) {
            req += &format!("Host: {}\r\n", self.addr);
        }
        for (k, v) in headers {
            req += &format!("{k}: {v}\r\n");
        }
        req += "\r\n";
        s.write_all(req.as_bytes()).unwrap();
        s.write_all(body).unwrap();
        let mut all = Vec::new();
        s.read_to_end(&mut all).unwrap();
        let split = all.windows(4).position(|w| w == b"\r\n\r\n").expect("end of headers");
        let head = String::from_utf8_lossy(&all[..split]).into_owned();
        let mut lines = head.lines();
        let status = lines.next().unwrap().split(' ').nth(1).unwrap().parse().unwrap();
        let headers = lines
            .filter_map(|l| l.split_once(':'))
            .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_string()))
            .collect();
        Answer { status, headers, body: all[split + 4..].to_vec() }
    }

    pub(crate) fn get(&self, path: &str) -> Answer {
        let sep = if path.contains('?') { '&' } else { '?' };
        self.raw("GET", &format!("{path}{sep}token={}", self.token), &[], b"")
    }

    pub(crate) fn post(&self, path: &str, body: &serde_json::Value) -> Answer {
        let token = self.token.clone();
        self.raw("POST", path, &[("X-Isoview-Token", &token)], body.to_string().as_bytes())
    }

    /// Posts `sets` and returns the new generation.
    pub(crate) fn set(&self, sets: &[&str]) -> u64 {
        let a = self.post("/api/state", &serde_json::json!({ "set": sets }));
        assert_eq!(a.status, 200, "{}", a.text());
        a.json()["generation"].as_u64().unwrap()
    }
}

/// `isoview render SCENE -o DIR/NAME.exr --png DIR/NAME.png --set ...`: (EXR bytes, PNG bytes).
pub(crate) fn cli_render(
    dir: &std::path::Path,
    name: &str,
    scene_file: &str,
    sets: &[&str],
) -> (Vec<u8>, Vec<u8>) {
    let (exr, png) = (dir.join(format!("{name}.exr")), dir.join(format!("{name}.png")));
    let mut args =
        vec!["render", scene_file, "-o", exr.to_str().unwrap(), "--png", png.to_str().unwrap()];
    for s in sets {
        args.extend(["--set", s]);
    }
    let o = isoview(&args, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    (std::fs::read(exr).unwrap(), std::fs::read(png).unwrap())
}

fn decode_png(bytes: &[u8]) -> image::RgbaImage {
    image::load_from_memory_with_format(bytes, image::ImageFormat::Png).unwrap().to_rgba8()
}

#[gpu_test]
fn frames_exrs_and_probes_equal_the_command_lines() {
    let dir = scratch("serve-equal");
    let file = scene("cell-tunnel.toml");
    let server = Server::start(&file, &["--set", "image.width=96", "--set", "image.height=80"]);
    let sets = [
        "image.width=96",
        "image.height=80",
        "surface.isovalue=0.05",
        "render.shading=lambert",
        "camera.eye=[2.0, 1.2, 1.9]",
    ];
    let generation = server.set(&sets);
    let frame = server.get("/api/frame");
    assert_eq!(frame.status, 200, "{}", frame.text());
    assert_eq!(frame.header("content-type"), "image/png");
    assert_eq!(frame.header("x-isoview-generation"), generation.to_string());
    assert_eq!(frame.header("x-isoview-level"), "full");
    let (exr, png) = cli_render(&dir, "a", &file, &sets);
    assert_eq!(decode_png(&frame.body), decode_png(&png), "pixels differ from render --png");
    assert_eq!(frame.body, png, "PNG bytes differ from render --png");

    let served = server.get("/api/exr");
    assert_eq!(served.status, 200, "{}", served.text());
    std::fs::write(dir.join("served.exr"), &served.body).unwrap();
    let (a, b) = (
        isoview::output::exr::read(&dir.join("served.exr")).unwrap(),
        isoview::output::exr::read(&dir.join("a.exr")).unwrap(),
    );
    assert_eq!(a.channels, b.channels, "EXR channels differ");
    let sorted = |mut v: Vec<(String, String)>| {
        v.sort();
        v
    };
    assert_eq!(sorted(a.attributes.clone()), sorted(b.attributes.clone()), "EXR header differs");
    assert_eq!(served.body, exr, "EXR bytes differ from render -o");

    // The AOV endpoint: raw f32 planes of the same frame.
    let aov = server.get("/api/aov?ch=Z,cell.X");
    assert_eq!(aov.status, 200, "{}", aov.text());
    let floats: Vec<f32> =
        aov.body.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    let n = 96 * 80;
    assert_eq!(floats.len(), 2 * n);
    let (z, cx) = (&b.channel("Z").unwrap().values, &b.channel("cell.X").unwrap().values);
    assert!(floats[..n].iter().zip(z).all(|(x, y)| x.to_bits() == y.to_bits()), "Z differs");
    assert_eq!(&floats[n..], &cx[..], "cell.X differs");

    for (x, y) in [(48, 40), (5, 7)] {
        let probe = server.get(&format!("/api/probe?x={x}&y={y}"));
        assert_eq!(probe.status, 200, "{}", probe.text());
        let pixel = format!("{x},{y}");
        let mut args = vec!["probe", &file, "--json", "--pixel", &pixel];
        for s in &sets {
            args.extend(["--set", s]);
        }
        let o = isoview(&args, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(probe.text(), String::from_utf8_lossy(&o.stdout), "probe ({x}, {y})");
    }
    let outside = server.get("/api/probe?x=96&y=0");
    assert_eq!(outside.status, 400);
    assert_eq!(outside.json()["error"], "isoview: --pixel 96,0: outside the 96x80 image");
}

#[gpu_test]
fn bad_overrides_get_the_cli_message_and_the_server_keeps_serving() {
    let file = scene("cell-tunnel.toml");
    let server = Server::start(&file, &["--set", "image.width=32", "--set", "image.height=32"]);
    let first = server.get("/api/frame");
    assert_eq!(first.status, 200, "{}", first.text());
    for bad in ["surface.isovalu=0.1", "render.steps=-3", "render.method=\"spline\"", "nokey"] {
        let a = server.post("/api/state", &serde_json::json!({ "set": ["image.width=32", bad] }));
        assert_eq!(a.status, 400, "{bad}: {}", a.text());
        let o = isoview(
            &["render", &file, "-o", "/nonexistent/x.exr", "--set", "image.width=32", "--set", bad],
            &[],
        );
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert_eq!(a.json()["error"].as_str().unwrap(), stderr(&o).trim_end(), "{bad}");
    }
    let not_json = server.raw("POST", &format!("/api/state?token={}", server.token), &[], b"{set");
    assert_eq!(not_json.status, 400);
    // Still serving, still generation 1.
    let again = server.get("/api/frame");
    assert_eq!(again.status, 200);
    assert_eq!(again.header("x-isoview-generation"), "1");
    assert_eq!(again.body, first.body);
    assert_eq!(server.set(&["image.width=32", "image.height=32", "surface.isovalue=0.1"]), 2);
}

/// A grid over the device's 3D images (4096 points per axis on lavapipe) was taken (200),
/// and its frame was a 500 that named no key; now the post is refused with `render`'s exit-2
/// line and the state stays as it was.
#[gpu_test]
fn a_grid_over_the_device_extent_is_refused_when_posted() {
    let file = scene("torus.toml");
    let server = Server::start(&file, &["--set", "image.width=16", "--set", "image.height=16"]);
    let bad = "field.resolution=[4097,2,2]";
    let a = server.post("/api/state", &serde_json::json!({ "set": [bad] }));
    assert_eq!(a.status, 400, "{}", a.text());
    let out = scratch("serve-device-extent").join("x.exr");
    let o = isoview(&["render", &file, "-o", out.to_str().unwrap(), "--set", bad], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("field.resolution [4097, 2, 2]: 4097 points along x"));
    assert_eq!(a.json()["error"].as_str().unwrap(), stderr(&o).trim_end());
    let state = server.get("/api/state");
    assert_eq!(state.json()["generation"], 1, "{}", state.text());
    assert_eq!(server.get("/api/frame").status, 200);
}

#[gpu_test]
fn a_wrong_token_or_a_foreign_host_is_refused() {
    let server = Server::start(
        &scene("cell-tunnel.toml"),
        &["--set", "image.width=16", "--set", "image.height=16"],
    );
    let ok = server.get("/api/state");
    assert_eq!(ok.status, 200, "{}", ok.text());
    let by_header =
        server.raw("GET", "/api/state", &[("X-Isoview-Token", &server.token.clone())], b"");
    assert_eq!(by_header.status, 200);
    let page = server.get("/");
    assert_eq!(page.status, 200);
    assert!(page.text().contains("<html"));
    for path in ["/api/state", "/api/frame", "/api/exr", "/", "/api/probe?x=1&y=1"] {
        assert_eq!(server.raw("GET", path, &[], b"").status, 403, "no token: {path}");
        let wrong = format!(
            "{path}{}token=00000000000000000000000000000000",
            if path.contains('?') { '&' } else { '?' }
        );
        assert_eq!(server.raw("GET", &wrong, &[], b"").status, 403, "wrong token: {path}");
    }
    let short = &server.token[..31];
    assert_eq!(server.raw("GET", &format!("/api/state?token={short}"), &[], b"").status, 403);
    let post = server.raw("POST", "/api/state", &[], br#"{"set": []}"#);
    assert_eq!(post.status, 403);
    // DNS rebinding: the right token, but a name that is not this machine.
    let token = server.token.clone();
    for host in ["evil.example", "evil.example:8000", "127.0.0.1.nip.io"] {
        let a = server.raw("GET", &format!("/api/state?token={token}"), &[("Host", host)], b"");
        assert_eq!(a.status, 403, "Host: {host}");
    }
    for host in ["localhost:8000", "127.0.0.1"] {
        let a = server.raw("GET", &format!("/api/state?token={token}"), &[("Host", host)], b"");
        assert_eq!(a.status, 200, "Host: {host}");
    }
}

#[gpu_test]
fn stale_states_are_dropped_and_previews_refine() {
    let file = scene("cell-tunnel.toml");
    let server = Server::start(&file, &[]);
    assert_eq!(server.get("/api/frame").status, 200);
    // A burst of states while the first of them renders: the latest wins, most never render.
    let posts = 12;
    let mut last = 0;
    for i in 0..posts {
        last = server.set(&[&format!("surface.isovalue={}", 0.01 * i as f64)]);
    }
    let frame = server.get("/api/frame");
    assert_eq!(frame.header("x-isoview-generation"), last.to_string());
    let stats = server.get("/api/stats").json();
    let full = stats["full_frames"].as_u64().unwrap();
    assert!(full < 1 + posts, "every state was rendered: {stats}");
    // The latest state's frame is the one shown.
    let dir = scratch("serve-stale");
    let (_, png) = cli_render(
        &dir,
        "last",
        &file,
        &[&format!("surface.isovalue={}", 0.01 * (posts - 1) as f64)],
    );
    assert_eq!(frame.body, png);

    // A preview: coarse first (every 4th pixel of the full image), then the full frame 150 ms
    // later. A test thread slower than that sees only the full frame: post again then.
    let (coarse, full, g) = (0..5)
        .find_map(|attempt| {
            let iso = format!("surface.isovalue={}", 0.02 + 0.001 * attempt as f64);
            let a = server.post("/api/state", &serde_json::json!({"set": [iso], "preview": true}));
            let g = a.json()["generation"].as_u64().unwrap();
            let first = server.get(&format!("/api/frame?after={}&level=full", g - 1));
            assert_eq!(first.status, 200);
            assert_eq!(first.header("x-isoview-generation"), g.to_string());
            if first.header("x-isoview-level") != "coarse" {
                return None;
            }
            let full = server.get(&format!("/api/frame?after={g}&level=coarse"));
            Some((first, full, g))
        })
        .expect("no coarse frame in 5 previews");
    assert_eq!(full.header("x-isoview-generation"), g.to_string());
    assert_eq!(full.header("x-isoview-level"), "full");
    let (c, f) = (decode_png(&coarse.body), decode_png(&full.body));
    assert_eq!((c.width(), c.height()), (f.width().div_ceil(4), f.height().div_ceil(4)));
    for (i, j, p) in c.enumerate_pixels() {
        assert_eq!(p, f.get_pixel(4 * i, 4 * j), "coarse ({i}, {j})");
    }
}

/// Packets as tev's protocol describes them: [u32 LE length incl. itself][u8 type][payload].
fn read_packets(mut stream: TcpStream) -> Vec<(u8, Vec<u8>)> {
    let mut all = Vec::new();
    stream.read_to_end(&mut all).unwrap();
    let mut packets = Vec::new();
    let mut at = 0;
    while at < all.len() {
        let len = u32::from_le_bytes(all[at..at + 4].try_into().unwrap()) as usize;
        assert!(len >= 5 && at + len <= all.len(), "packet length {len} at {at} of {}", all.len());
        packets.push((all[at + 4], all[at + 5..at + len].to_vec()));
        at += len;
    }
    packets
}

/// A cursor over a packet's payload.
struct Payload<'a>(&'a [u8]);

impl Payload<'_> {
    fn take(&mut self, n: usize) -> &[u8] {
        let (a, b) = self.0.split_at(n);
        self.0 = b;
        a
    }
    fn u8(&mut self) -> u8 {
        self.take(1)[0]
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let end = self.0.iter().position(|&b| b == 0).expect("NUL-terminated string");
        let s = String::from_utf8(self.take(end).to_vec()).unwrap();
        self.take(1);
        s
    }
}

/// One UpdateImage v3 packet's payload, decoded.
struct Update {
    image: String,
    chans: Vec<String>,
    x: usize,
    y: usize,
    w: usize,
    h: usize,
    offsets: Vec<i64>,
    strides: Vec<i64>,
    data: Vec<f32>,
}

impl Update {
    fn parse(body: &[u8]) -> Update {
        let mut p = Payload(body);
        p.u8();
        let image = p.string();
        let n = p.i32() as usize;
        let chans: Vec<String> = (0..n).map(|_| p.string()).collect();
        let (x, y, w, h) = (p.i32() as usize, p.i32() as usize, p.i32() as usize, p.i32() as usize);
        let offsets: Vec<i64> = (0..n).map(|_| p.i64()).collect();
        let strides: Vec<i64> = (0..n).map(|_| p.i64()).collect();
        let data = p.0.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
        Update { image, chans, x, y, w, h, offsets, strides, data }
    }
}

/// Decodes CreateImage + UpdateImage v3 packets into (name, width, height, channel -> values).
fn decode_tev(packets: &[(u8, Vec<u8>)]) -> (String, usize, usize, HashMap<String, Vec<f32>>) {
    let (kind, body) = &packets[0];
    assert_eq!(*kind, 4, "CreateImage first");
    let mut p = Payload(body);
    p.u8();
    let name = p.string();
    let (w, h, n) = (p.i32() as usize, p.i32() as usize, p.i32() as usize);
    let names: Vec<String> = (0..n).map(|_| p.string()).collect();
    assert!(p.0.is_empty());
    let mut planes: HashMap<String, Vec<f32>> =
        names.iter().map(|c| (c.clone(), vec![f32::NAN; w * h])).collect();
    let mut covered = vec![0u32; w * h];
    for (kind, body) in &packets[1..] {
        assert_eq!(*kind, 6, "UpdateImage v3");
        let Update { image, chans, x, y, w: rw, h: rh, offsets, strides, data } =
            Update::parse(body);
        assert_eq!(image, name);
        for (c, name) in chans.iter().enumerate() {
            let plane = planes.get_mut(name).expect("channel created");
            for q in 0..rw * rh {
                let v = data[(offsets[c] + q as i64 * strides[c]) as usize];
                plane[(y + q / rw) * w + x + q % rw] = v;
            }
        }
        for q in 0..rw * rh {
            covered[(y + q / rw) * w + x + q % rw] += 1;
        }
    }
    assert!(covered.iter().all(|&c| c == 1), "every pixel sent exactly once");
    (name, w, h, planes)
}

/// The EXR's channels equal the decoded tev image's, bit for bit.
fn assert_same_as_exr(
    exr: &std::path::Path,
    (_, w, h, planes): &(String, usize, usize, HashMap<String, Vec<f32>>),
) {
    let image = isoview::output::exr::read(exr).unwrap();
    assert_eq!((image.width, image.height), (*w, *h));
    let mut names: Vec<&str> = planes.keys().map(String::as_str).collect();
    names.sort();
    let exr_names: Vec<&str> = image.channel_names().collect();
    assert_eq!(names, exr_names, "tev gets every EXR channel");
    for c in &image.channels {
        let sent = &planes[&c.name];
        assert!(
            sent.iter().zip(&c.values).all(|(a, b)| a.to_bits() == b.to_bits()),
            "{} differs",
            c.name
        );
    }
}

#[gpu_test]
fn render_and_serve_push_every_channel_to_tev() {
    let dir = scratch("serve-tev");
    let file = scene("cell-tunnel.toml");
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let exr = dir.join("t.exr");
    // 150 rows: three packets of 64, 64 and 22 rows.
    let sets = ["image.width=70", "image.height=150", "render.count_crossings=true"];
    let receiver = std::thread::spawn(move || read_packets(listener.accept().unwrap().0));
    let mut args = vec!["render", &file, "-o", exr.to_str().unwrap(), "--tev", &address];
    for s in &sets {
        args.extend(["--set", s]);
    }
    let o = isoview(&args, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let packets = receiver.join().unwrap();
    assert_eq!(packets.len(), 1 + 3);
    let decoded = decode_tev(&packets);
    assert_eq!(decoded.0, exr.display().to_string());
    assert!(decoded.3.contains_key("crossings"));
    assert_same_as_exr(&exr, &decoded);

    // The page's button: the served frame, the same channels.
    let server = Server::start(&file, &sets.iter().flat_map(|s| ["--set", s]).collect::<Vec<_>>());
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let receiver = std::thread::spawn(move || read_packets(listener.accept().unwrap().0));
    let a = server.post("/api/tev", &serde_json::json!({ "address": address }));
    assert_eq!(a.status, 200, "{}", a.text());
    assert_same_as_exr(&exr, &decode_tev(&receiver.join().unwrap()));

    // Nobody listening: one line naming the address, exit 2.
    let closed = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string();
    let o = isoview(
        &[
            "render",
            &file,
            "-o",
            exr.to_str().unwrap(),
            "--set",
            "image.width=8",
            "--set",
            "image.height=8",
            "--tev",
            &closed,
        ],
        &[],
    );
    crate::common::assert_fails(&o, 2, &[&closed, "cannot connect"]);
    let a = server.post("/api/tev", &serde_json::json!({ "address": closed }));
    assert_eq!(a.status, 502, "{}", a.text());
}

#[gpu_test]
fn slices_and_saved_scenes_match_the_command_line() {
    let dir = scratch("serve-slice");
    let file = scene("cell-tunnel.toml");
    let server = Server::start(&file, &["--set", "image.width=64", "--set", "image.height=64"]);
    let sets = ["image.width=64", "image.height=64", "surface.isovalue=0.1"];
    server.set(&sets);
    let (json, svg, png) = (dir.join("c.json"), dir.join("c.svg"), dir.join("c.png"));
    let mut args = vec![
        "slice",
        &file,
        "-o",
        "/dev/null/x.exr",
        "--axis",
        "z",
        "--at",
        "0.4",
        "--json",
        json.to_str().unwrap(),
        "--svg",
        svg.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
    ];
    let exr = dir.join("c.exr");
    args[3] = exr.to_str().unwrap();
    for s in &sets {
        args.extend(["--set", s]);
    }
    let o = isoview(&args, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    for (format, path) in [("json", &json), ("svg", &svg), ("png", &png)] {
        let a = server.get(&format!("/api/slice?axis=z&at=0.4&format={format}"));
        assert_eq!(a.status, 200, "{format}: {}", a.text());
        assert_eq!(a.body, std::fs::read(path).unwrap(), "slice {format}");
    }
    let cells = server.get("/api/slice?axis=z&at=0.4&format=cells").json();
    assert_eq!(cells["values"].as_array().unwrap().len(), 4);
    let outside = server.get("/api/slice?axis=z&at=7&format=json");
    assert_eq!(outside.status, 400, "{}", outside.text());

    // The saved scene loads to the state: its probe equals the served one.
    let saved = server.get("/api/scene.toml");
    assert_eq!(saved.status, 200);
    let path = crate::common::write(&dir, "saved.toml", &saved.text());
    let o = isoview(&["probe", &path, "--json", "--pixel", "30,30"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut from_file: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let mut served = server.get("/api/probe?x=30&y=30").json();
    from_file["scene"] = serde_json::Value::Null;
    served["scene"] = serde_json::Value::Null;
    assert_eq!(from_file, served);
}

#[gpu_test]
fn coarse_pixels_are_the_full_images_and_stale_renders_stop_between_bands() {
    use isoview::render::{GpuGrid, Progressive, RenderError, Renderer};
    use isoview::scene::Method;
    let ctx = crate::common::gpu();
    let mut renderer = Renderer::new(&ctx).unwrap();
    for method in [Method::Analytic, Method::FixedStep] {
        let mut scene =
            isoview::scene::load(std::path::Path::new(&scene("torus.toml")), &[]).unwrap();
        scene.image = isoview::scene::ImageSettings { width: 103, height: 61 };
        scene.render.method = method;
        let grid = scene.field.sample(0.0).unwrap();
        let gpu = GpuGrid::upload(&ctx, &grid).unwrap();
        let full = renderer.render_uploaded(&scene, &grid, &gpu, 0.0).unwrap();
        let mut bands = 0;
        let mut count = |_: isoview::passes::Band, _: &[isoview::frame::Pixel]| {
            bands += 1;
            true
        };
        let how = Progressive { stride: 4, band_rows: 5, after_band: &mut count };
        let coarse = renderer.render_progressive(&scene, &grid, &gpu, 0.0, how).unwrap();
        assert_eq!((coarse.width, coarse.height), (26, 16));
        assert_eq!(bands, 4, "16 rows in bands of 5");
        for j in 0..coarse.height {
            for i in 0..coarse.width {
                let (a, b) = (coarse.pixel(i, j), full.pixel(4 * i, 4 * j));
                assert_eq!(bytemuck::bytes_of(a), bytemuck::bytes_of(b), "{method:?} ({i}, {j})");
            }
        }
        let mut calls = 0;
        let mut stop_after_two = |_: isoview::passes::Band, _: &[isoview::frame::Pixel]| {
            calls += 1;
            calls < 2
        };
        let how = Progressive { stride: 1, band_rows: 8, after_band: &mut stop_after_two };
        let stopped = renderer.render_progressive(&scene, &grid, &gpu, 0.0, how);
        assert!(matches!(stopped, Err(RenderError::Cancelled)));
        assert_eq!(calls, 2, "no band after the stop");
    }
}

/// `render --tev` sends each band as the renderer finishes it: the UpdateImage packets follow
/// the render's bands (chunks of at most 64 rows within each band), not a split of the
/// finished image, and together they are the EXR bit for bit.
#[gpu_test]
fn render_tev_streams_each_band_as_it_is_drawn() {
    let (w, h) = (1200u32, 900u32);
    let ctx = crate::common::gpu();
    let pixel = std::mem::size_of::<isoview::frame::Pixel>() as u64;
    let band = isoview::render::band_rows(&ctx, w, h, pixel);
    drop(ctx);
    assert!(band < h && band % 64 != 0, "two bands, the first not a multiple of 64: {band}");
    let mut want = Vec::new();
    for start in (0..h).step_by(band as usize) {
        let end = (start + band).min(h);
        for y in (start..end).step_by(64) {
            want.push((y as usize, (end - y).min(64) as usize));
        }
    }
    let dir = scratch("serve-tev-bands");
    let file = scene("cell-tunnel.toml");
    let exr = dir.join("t.exr");
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let receiver = std::thread::spawn(move || read_packets(listener.accept().unwrap().0));
    let (ws, hs) = (format!("image.width={w}"), format!("image.height={h}"));
    let o = isoview(
        &[
            "render",
            &file,
            "-o",
            exr.to_str().unwrap(),
            "--set",
            &ws,
            "--set",
            &hs,
            "--tev",
            &address,
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let packets = receiver.join().unwrap();
    let rows: Vec<(usize, usize)> = packets[1..]
        .iter()
        .map(|(_, body)| {
            let u = Update::parse(body);
            (u.y, u.h)
        })
        .collect();
    assert_eq!(rows, want, "UpdateImage rows follow the render's bands of {band} rows");
    assert_same_as_exr(&exr, &decode_tev(&packets));
}

/// The page's interpolation selector posts `field.interpolation`: a state whose method reads it
/// is rendered and `/api/state` says which; one whose method does not answers 400 with the
/// command line's line and the shown state stays.
#[gpu_test]
fn the_interpolation_is_a_state_like_any_key() {
    let file = scene("torus.toml");
    let server = Server::start(&file, &["--set", "image.width=16", "--set", "image.height=16"]);
    assert_eq!(server.get("/api/state").json()["field"]["interpolation"], "trilinear");
    let ok = ["field.interpolation=\"catmull-rom\"", "render.method=\"fixed-step\""];
    let a = server.post("/api/state", &serde_json::json!({ "set": ok }));
    assert_eq!(a.status, 200, "{}", a.text());
    let state = server.get("/api/state").json();
    assert_eq!(state["field"]["interpolation"], "catmull-rom", "{state}");
    assert_eq!(server.get("/api/frame").status, 200);
    // The cubic ones are traced exactly too; "device" is only sampled.
    let traced = ["field.interpolation=\"catmull-rom\"", "render.method=\"analytic\""];
    let t = server.post("/api/state", &serde_json::json!({ "set": traced }));
    assert_eq!(t.status, 200, "{}", t.text());
    let generation = server.get("/api/state").json()["generation"].clone();
    let bad = ["field.interpolation=\"device\"", "render.method=\"analytic\""];
    let b = server.post("/api/state", &serde_json::json!({ "set": bad }));
    assert_eq!(b.status, 400, "{}", b.text());
    let line = b.json()["error"].as_str().unwrap().to_string();
    let why = "field.interpolation = \"device\": \"device\" is what the GPU's texture unit returns";
    assert!(line.contains(why), "{line}");
    assert_eq!(server.get("/api/state").json()["generation"], generation);
    let page = server.get("/").text();
    assert!(page.contains("<select id=\"interpolation\">"), "the page's selector");
}
