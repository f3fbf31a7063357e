//! `isoview serve` under the requests that broke it (issue 29): each test sends the attack
//! over loopback to the binary and checks the server answers it, stays up and stays small.
//! Memory and threads are read from /proc/PID/status, with generous bounds. Times are
//! asserted only where the attack was a wait (idle connections, a closed long-poll), with
//! bounds several times what the server needs and well under what the attack used to cost.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use serde_json::json;

use crate::common::{isoview, scratch, stderr, write};
use crate::serve::api::{scene, Answer, Server};

/// A line of the server's /proc/PID/status (`VmRSS`, `Threads`), as a number (kB for sizes).
fn status_of(server: &Server, key: &str) -> u64 {
    let text = std::fs::read_to_string(format!("/proc/{}/status", server.child.id())).unwrap();
    let line = text.lines().find(|l| l.starts_with(&format!("{key}:"))).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

fn rss_mib(server: &Server) -> f64 {
    status_of(server, "VmRSS") as f64 / 1024.0
}

/// Sends `request` whole and reads the answer: (status, body); status 0 when the server
/// closed the connection without one.
fn exchange(server: &Server, request: &[u8]) -> (u16, String) {
    let mut s = TcpStream::connect(&server.addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let _ = s.write_all(request);
    read_answer(&mut s)
}

fn read_answer(s: &mut TcpStream) -> (u16, String) {
    let mut all = Vec::new();
    let mut buf = [0u8; 65536];
    // A reset after the answer (the server closed with our bytes unread) still leaves it read.
    while let Ok(n) = s.read(&mut buf) {
        if n == 0 {
            break;
        }
        all.extend_from_slice(&buf[..n]);
    }
    let text = String::from_utf8_lossy(&all).into_owned();
    let status = text.split(' ').nth(1).and_then(|c| c.parse().ok()).unwrap_or(0);
    let body = text.split_once("\r\n\r\n").map_or(String::new(), |(_, b)| b.to_string());
    (status, body)
}

/// A server on the cell-tunnel scene at 16 x 16 pixels: what most attacks need.
fn small_server() -> Server {
    Server::start(
        &scene("cell-tunnel.toml"),
        &["--set", "image.width=16", "--set", "image.height=16"],
    )
}

/// A GET of each of `paths`, each on its own thread of `scope`: the path, the answer and when
/// it came.
fn get_each<'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    server: &'scope Server,
    paths: impl Iterator<Item = &'static str>,
) -> Vec<std::thread::ScopedJoinHandle<'scope, (&'static str, Answer, Instant)>> {
    let ask = move |path| move || (path, server.get(path), Instant::now());
    paths.map(|path| scope.spawn(ask(path))).collect()
}

fn alive(server: &Server) {
    let a = server.get("/api/state");
    assert_eq!(a.status, 200, "the server still answers: {}", a.text());
}

#[gpu_test]
fn oversized_requests_are_refused_before_they_are_read() {
    let server = small_server();
    alive(&server);
    let before = rss_mib(&server);
    // A request line of 256 MiB, unauthenticated: the server reads 16 KiB of it, answers 414
    // and closes, so the sender's writes fail long before the end.
    let mut s = TcpStream::connect(&server.addr).unwrap();
    s.set_write_timeout(Some(Duration::from_secs(60))).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let chunk = vec![b'a'; 1 << 20];
    let mut sent = s.write_all(b"GET /").map(|_| 5usize);
    for _ in 0..256 {
        match s.write_all(&chunk) {
            Ok(()) => sent = sent.map(|n| n + chunk.len()),
            Err(e) => {
                sent = Err(e);
                break;
            }
        }
    }
    assert!(sent.is_err(), "the server read a 256 MiB request line ({sent:?} bytes taken)");
    let grown = rss_mib(&server) - before;
    assert!(grown < 32.0, "the server grew by {grown:.1} MiB reading a huge request line");
    alive(&server);

    // The same with a request whose bytes all fit in the socket: the answers say what is wrong.
    let line = format!("GET /{} HTTP/1.1\r\nHost: {}\r\n\r\n", "a".repeat(20 << 10), server.addr);
    assert_eq!(exchange(&server, line.as_bytes()).0, 414);
    let big = format!("GET / HTTP/1.1\r\nHost: x\r\nX-A: {}\r\n\r\n", "a".repeat(20 << 10));
    assert_eq!(exchange(&server, big.as_bytes()).0, 431);
    let many = format!("GET / HTTP/1.1\r\n{}\r\n", "X-A: 1\r\n".repeat(100));
    assert_eq!(exchange(&server, many.as_bytes()).0, 431);
    assert_eq!(exchange(&server, b"\x16\x03\x01 not http\r\n\r\n").0, 400);
    // A body over 1 MiB is refused from its Content-Length, with the token; without the token
    // the answer is 403 and no body is read at all.
    let token = server.token.clone();
    let over = format!(
        "POST /api/state?token={token} HTTP/1.1\r\nHost: {}\r\nContent-Length: {}\r\n\r\n",
        server.addr,
        (1 << 20) + 1
    );
    assert_eq!(exchange(&server, over.as_bytes()).0, 413);
    let anonymous = format!(
        "POST /api/state HTTP/1.1\r\nHost: {}\r\nContent-Length: 1000000000\r\n\r\n{{}}",
        server.addr
    );
    assert_eq!(exchange(&server, anonymous.as_bytes()).0, 403);
    let chunked = format!(
        "POST /api/state?token={token} HTTP/1.1\r\nHost: {}\r\nTransfer-Encoding: chunked\r\n\r\n",
        server.addr
    );
    assert_eq!(exchange(&server, chunked.as_bytes()).0, 411);
    alive(&server);
}

#[gpu_test]
fn many_connections_take_no_more_threads_and_the_excess_is_told_to_wait() {
    let server = small_server();
    alive(&server);
    let threads = status_of(&server, "Threads");
    // 150 connections that send nothing: the first 64 hold slots, the rest get 503 at once.
    let idle: Vec<TcpStream> =
        (0..150).map(|_| TcpStream::connect(&server.addr).unwrap()).collect();
    let mut busy = 0;
    for s in idle.iter().skip(100) {
        let mut s = s.try_clone().unwrap();
        s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        let (status, body) = read_answer(&mut s);
        // 408: on a machine so slow that the first idle ones timed out and freed their slots.
        assert!(status == 503 || status == 408, "{status}: {body}");
        busy += (status == 503) as usize;
    }
    assert!(busy >= 40, "{busy} of the last 50 connections were told to wait");
    let now = status_of(&server, "Threads");
    assert!(now <= threads + 4, "{threads} threads before 150 connections, {now} with them");
    drop(idle);
    // The idle ones time out (5 s for a request head); then requests are served again.
    let s = &server;
    let ok = (0..60).any(|_| {
        std::thread::sleep(Duration::from_millis(500));
        s.get("/api/state").status == 200
    });
    assert!(ok, "the server serves again once the idle connections are gone");
}

#[gpu_test]
fn parked_long_polls_leave_the_workers_free() {
    let server = small_server();
    assert_eq!(server.get("/api/frame").status, 200);
    let generation = server.get("/api/state").json()["generation"].as_u64().unwrap();
    // 40 tabs waiting for a newer frame: 32 park, the rest are told to come back.
    let poll = format!(
        "GET /api/frame?after={generation}&level=full&token={} HTTP/1.1\r\nHost: {}\r\n\r\n",
        server.token, server.addr
    );
    let polls: Vec<TcpStream> = (0..40)
        .map(|_| {
            let mut s = TcpStream::connect(&server.addr).unwrap();
            s.write_all(poll.as_bytes()).unwrap();
            s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
            s
        })
        .collect();
    // Every worker would be waiting if the polls held them (LONG_POLL is 25 s): this request
    // would then time out after 20 s.
    let mut s = TcpStream::connect(&server.addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    let get =
        format!("GET /api/stats?token={} HTTP/1.1\r\nHost: {}\r\n\r\n", server.token, server.addr);
    s.write_all(get.as_bytes()).unwrap();
    let (status, body) = read_answer(&mut s);
    assert_eq!(status, 200, "a request beside 40 long-polls: {body}");
    // A new state answers every parked poll with its frame.
    let newer = server.set(&["image.width=16", "image.height=16", "surface.isovalue=0.1"]);
    let mut statuses = std::collections::BTreeMap::new();
    for mut p in polls {
        let (status, _) = read_answer(&mut p);
        *statuses.entry(status).or_insert(0) += 1;
    }
    assert_eq!(statuses.get(&200), Some(&32), "{statuses:?}");
    assert_eq!(statuses.get(&503), Some(&8), "{statuses:?}");
    assert_eq!(server.get("/api/frame").header("x-isoview-generation"), newer.to_string());
}

/// A scene over a 2x2x2 u8 raw file in `dir/scene/`, with `dir/allowed/` and `dir/outside/`
/// holding other files, and a link in the scene's folder pointing outside.
fn path_fixture(name: &str) -> (std::path::PathBuf, String) {
    let dir = scratch(name);
    for sub in ["scene", "allowed", "outside"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    let cube: Vec<u8> = vec![0, 10, 20, 30, 40, 50, 60, 70];
    std::fs::write(dir.join("scene/data.raw"), &cube).unwrap();
    std::fs::write(dir.join("allowed/other.raw"), &cube).unwrap();
    std::fs::write(dir.join("outside/secret.raw"), b"SECRET!!").unwrap();
    // The MetaImage reader quotes a line it cannot read.
    std::fs::write(dir.join("scene/bad.mhd"), "SECRET-LINE-7f3a\n").unwrap();
    let _ = std::fs::remove_file(dir.join("scene/link.raw"));
    std::os::unix::fs::symlink(dir.join("outside/secret.raw"), dir.join("scene/link.raw")).unwrap();
    let file = write(
        &dir.join("scene"),
        "scene.toml",
        "[image]\nwidth = 16\nheight = 16\n\n[camera]\neye = [3.0, 2.0, 2.5]\n\
         target = [0.5, 0.5, 0.5]\n\n[field]\nsource = \"raw\"\npath = \"data.raw\"\n\
         dims = [2, 2, 2]\ndtype = \"u8\"\n\n[surface]\nisovalue = 35.0\n",
    );
    (dir, file)
}

fn raw_field(path: &str) -> String {
    format!("field = {{source = \"raw\", path = \"{path}\", dims = [2, 2, 2], dtype = \"u8\"}}")
}

#[gpu_test]
fn the_page_reads_only_the_scenes_files_and_allowed_folders() {
    let (dir, file) = path_fixture("serve-paths");
    let allowed = dir.join("allowed");
    let server = Server::start(&file, &["--allow-dir", allowed.to_str().unwrap()]);
    alive(&server);
    let secret = dir.join("outside/secret.raw");
    let refused = [
        secret.display().to_string(),
        "../outside/secret.raw".into(),
        "../scene/../outside/secret.raw".into(),
        "link.raw".into(),
        "/etc/passwd".into(),
        "../outside/missing.raw".into(),
    ];
    for path in &refused {
        let a = server.post("/api/state", &json!({ "set": [raw_field(path)] }));
        assert_eq!(a.status, 400, "{path}: {}", a.text());
        let e = a.json()["error"].as_str().unwrap().to_string();
        assert!(e.contains("field.path") && e.contains("--allow-dir"), "{path}: {e}");
        assert!(!e.contains("SECRET"), "{path}: {e}");
    }
    // The same refusal for the colour-by field's path.
    let a = server.post(
        "/api/state",
        &json!({ "set": [
            "field2 = {source = \"raw\", path = \"../outside/secret.raw\", dims = [2, 2, 2], dtype = \"u8\"}",
            "color.by = \"field2\"",
        ] }),
    );
    assert_eq!(a.status, 400, "{}", a.text());
    assert!(a.json()["error"].as_str().unwrap().contains("field2.path"), "{}", a.text());
    // Nothing of the secret reached the field.
    let cells = server.get("/api/slice?axis=z&at=0&format=cells").json();
    assert_eq!(cells["values"][0], json!(0.0), "{cells}");

    // Inside: the scene's folder, the allowed folder (by an absolute path and by `..`).
    let other = allowed.join("other.raw").display().to_string();
    for path in ["data.raw", other.as_str(), "../allowed/other.raw"] {
        let a = server.post("/api/state", &json!({ "set": [raw_field(path)] }));
        assert_eq!(a.status, 200, "{path}: {}", a.text());
    }
    let cells = server.get("/api/slice?axis=z&at=0&format=cells").json();
    assert_eq!(cells["values"], json!([0.0, 10.0, 20.0, 30.0]), "{cells}");

    // A file in the folder that is not what it claims: named, its contents not quoted.
    let a = server
        .post("/api/state", &json!({ "set": ["field = {source = \"file\", path = \"bad.mhd\"}"] }));
    assert_eq!(a.status, 400, "{}", a.text());
    let e = a.json()["error"].as_str().unwrap().to_string();
    assert!(e.contains("bad.mhd") && e.contains("MetaImage") && !e.contains("SECRET"), "{e}");
    // The command line (the user's own terminal) still says what is wrong in full.
    let o = isoview(
        &[
            "render",
            &file,
            "-o",
            "/nonexistent/x.exr",
            "--set",
            "field = {source = \"file\", path = \"bad.mhd\"}",
        ],
        &[],
    );
    crate::common::assert_fails(&o, 2, &["bad.mhd", "SECRET-LINE-7f3a"]);
    alive(&server);
}

#[gpu_test]
fn a_missing_allow_dir_is_refused_at_start() {
    let (dir, file) = path_fixture("serve-paths-missing");
    let missing = dir.join("no-such-folder");
    let o =
        isoview(&["serve", &file, "--port", "0", "--allow-dir", missing.to_str().unwrap()], &[]);
    crate::common::assert_fails(&o, 2, &["--allow-dir", "no-such-folder", "file not found"]);
    // Fifth attack pass: a regular file, a FIFO or a device node was taken without a word
    // (the option names a folder; a typo went unnoticed).
    let fifo = dir.join("pipe");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    for (path, kind) in [
        (file.as_str(), "a regular file"),
        (fifo.to_str().unwrap(), "a FIFO"),
        ("/dev/null", "a character device"),
    ] {
        // Under `timeout`: a server that starts runs until killed (exit 124, a failure).
        let o = std::process::Command::new("timeout")
            .args(["30", env!("CARGO_BIN_EXE_isoview"), "serve", &file, "--port", "0"])
            .args(["--allow-dir", path])
            .env_remove("ISOVIEW_DEVICE")
            .output()
            .unwrap();
        crate::common::assert_fails(&o, 2, &["--allow-dir ", ": is ", kind, ", not a folder"]);
    }
}

/// exmex's own messages print its tokens with `Debug` (function addresses): never shown.
#[test]
fn expression_errors_are_one_clean_line() {
    let dir = scratch("expr-errors");
    let file = write(
        &dir,
        "e.toml",
        "[field]\nsource = \"expr\"\nexpression = \"x\"\nresolution = [4, 4, 4]\n\
         bounds = { min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0] }\n",
    );
    for (expr, want) in [
        // exmex's message for this one prints its operator with Debug: `Operator { repr: "*",
        // bin_op: Some(BinOp { apply: 0x5625cd2573f0, ...`.
        ("x +* y", "a value is missing before \"*\" at character 4"),
        ("x * * y", "a value is missing before \"*\" at character 5"),
        ("sin(x", "\"(\" at character 4 is never closed"),
        ("x +", "ends where a value is expected"),
        ("2 x", "follows a value without an operator"),
        ("x ) + (", "\")\" at character 3 has no matching \"(\""),
    ] {
        let set = format!("field.expression={expr:?}");
        let o = isoview(&["render", &file, "-o", "/nonexistent/x.exr", "--set", &set], &[]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{expr}: {e}");
        assert!(e.contains(want), "{expr}: {e}");
        assert!(
            !e.contains("0x") && !e.contains("Operator") && !e.contains("Paren"),
            "{expr}: {e}"
        );
        assert_eq!(e.trim_end().lines().count(), 1, "{expr}: {e}");
    }
    // Third #29 pass: 100,000 nested `sin(` took the parser 8 s (300,000 over a minute, and
    // ten such states held every serve worker); over 4096 bytes is refused before parsing,
    // the expression echoed cut.
    let deep = format!("{}x{}", "sin(".repeat(100_000), ")".repeat(100_000));
    let scene = format!(
        "[field]\nsource = \"expr\"\nexpression = \"{deep}\"\nresolution = [4, 4, 4]\n\
         bounds = {{ min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0] }}\n"
    );
    let long = write(&dir, "long.toml", &scene);
    let started = std::time::Instant::now();
    let o = isoview(&["stats", &long], &[]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("500001 bytes, over the 4096 an expression may have"), "{e}");
    assert!(e.len() < 600 && e.trim_end().lines().count() == 1, "{} bytes", e.len());
    assert!(started.elapsed().as_secs() < 30, "refused before parsing");
    // Fourth pass: names and numbers inside the expression were quoted whole (4 KiB lines)
    // and unescaped (ESC, U+202E reached serve's page).
    for expr in [
        format!("x + {}", "a".repeat(3000)),
        format!("x + f{}(x)", "b".repeat(3000)),
        format!("{}e5 * x", "1".repeat(3000)),
        "x + a\u{1b}b\u{202e}c".to_string(),
    ] {
        let set = format!("field.expression={expr:?}");
        let o = isoview(&["stats", &file, "--set", &set], &[]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(e.len() < 700 && e.trim_end().lines().count() == 1, "{} bytes: {e}", e.len());
        assert!(!e.contains('\u{1b}') && !e.contains('\u{202e}'), "{e}");
    }
}

/// A 40 KB state whose key path has 20,000 segments overflowed a worker's stack and killed
/// the server (rc 134); now 400 with the command line's line, and the server serves on.
#[gpu_test]
fn a_deep_key_path_is_refused_not_a_stack_overflow() {
    let server = small_server();
    let deep = format!("{}=1", vec!["a"; 20_000].join("."));
    let a = server.post("/api/state", &json!({ "set": [deep] }));
    assert_eq!(a.status, 400, "{}", a.text());
    let e = a.json()["error"].as_str().unwrap().to_string();
    assert!(e.ends_with("a key path of 20000 segments; scene keys have at most 16"), "{e}");
    alive(&server);
}

#[gpu_test]
fn serve_expression_errors_are_one_clean_line() {
    let server = Server::start(
        &scene("expr-waves.toml"),
        &["--set", "image.width=16", "--set", "image.height=16"],
    );
    let a = server.post("/api/state", &json!({ "set": ["field.expression = \"x +* y\""] }));
    assert_eq!(a.status, 400, "{}", a.text());
    let e = a.json()["error"].as_str().unwrap().to_string();
    assert!(e.contains("character 4") && !e.contains("0x") && !e.contains("Operator"), "{e}");
}

#[gpu_test]
fn images_over_the_pixel_cap_are_refused() {
    let file = scene("cell-tunnel.toml");
    let server = Server::start(&file, &["--set", "image.width=16", "--set", "image.height=16"]);
    let a = server.post("/api/state", &json!({ "set": ["image.width=8192", "image.height=8192"] }));
    assert_eq!(a.status, 400, "{}", a.text());
    let e = a.json()["error"].as_str().unwrap().to_string();
    assert!(e.contains("67108864 pixels") && e.contains("--max-pixels"), "{e}");
    alive(&server);
    drop(server);
    // The cap is the user's: raised or lowered on the command line, checked at start too.
    let o = isoview(
        &[
            "serve",
            &file,
            "--port",
            "0",
            "--max-pixels",
            "399",
            "--set",
            "image.width=20",
            "--set",
            "image.height=20",
        ],
        &[],
    );
    crate::common::assert_fails(&o, 2, &["20x20", "400 pixels", "399", "--max-pixels"]);
    let server = Server::start(
        &file,
        &["--max-pixels", "400", "--set", "image.width=20", "--set", "image.height=20"],
    );
    assert_eq!(
        server.post("/api/state", &json!({ "set": ["image.width=20", "image.height=20"] })).status,
        200
    );
    let a = server.post("/api/state", &json!({ "set": ["image.width=21", "image.height=20"] }));
    assert_eq!(a.status, 400, "{}", a.text());
    // The slice picture counts too: 16384² took serve to 9.6 GB (third attack pass).
    let image = ["image.width=20", "image.height=20"];
    let set = [&image[..], &["slice.width=16384", "slice.height=16384"]].concat();
    assert_eq!(server.post("/api/state", &json!({ "set": set })).status, 200);
    let a = server.get("/api/slice?axis=z&at=0&format=png");
    assert_eq!(a.status, 400, "{}", a.text());
    let e = a.json()["error"].as_str().unwrap().to_string();
    assert!(e.contains("16384x16384") && e.contains("400 pixels") && e.contains("--max-pixels"));
    let set = [&image[..], &["slice.width=20", "slice.height=20"]].concat();
    assert_eq!(server.post("/api/state", &json!({ "set": set })).status, 200);
    assert_eq!(server.get("/api/slice?axis=z&at=0&format=png").status, 200);
    alive(&server);
}

/// Each state renders 4 bands of 32 rows; lavapipe used to keep ~1 MiB per band for good
/// (+4.3 MiB per state here). Now the pipelines are released every 16 dispatches: the server
/// grows by well under 1 MiB per state (the driver keeps ~70 KiB per dispatch).
#[gpu_test]
fn memory_per_state_stays_flat() {
    let server = Server::start(
        &scene("cell-tunnel.toml"),
        &["--set", "image.width=128", "--set", "image.height=128"],
    );
    let states = |from: usize, to: usize| {
        for i in from..to {
            let iso = format!("surface.isovalue={}", 0.001 * i as f64);
            server.set(&["image.width=128", "image.height=128", &iso]);
            assert_eq!(server.get("/api/frame").status, 200);
        }
    };
    states(0, 20);
    let before = rss_mib(&server);
    states(20, 80);
    let grown = rss_mib(&server) - before;
    assert!(grown < 40.0, "grew {grown:.1} MiB over 60 states of 128x128");
}

/// A detached header inside an allowed folder naming a data file outside them: refused like a
/// `path` key, naming the header key (not the path the header holds); nothing of the file
/// reaches the field, not even its size. Inside the folders, detached data still reads, and
/// the command line still reads whatever its headers name.
#[gpu_test]
fn detached_headers_read_only_inside_the_allowed_folders() {
    let (dir, file) = path_fixture("serve-detached");
    let secret = dir.join("outside/secret.raw");
    let scene_dir = dir.join("scene");
    let mhd = |data: &str| {
        format!("NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = {data}\n")
    };
    let nhdr = |data: &str| {
        format!(
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: {data}\n"
        )
    };
    let cases = [
        ("abs.mhd", mhd(&secret.display().to_string()), "ElementDataFile"),
        ("rel.mhd", mhd("../outside/secret.raw"), "ElementDataFile"),
        ("link.mhd", mhd("link.raw"), "ElementDataFile"),
        // 8 bytes were expected: the size of /etc/passwd was in the mismatch message.
        ("etc.mhd", mhd("/etc/passwd"), "ElementDataFile"),
        ("abs.nhdr", nhdr(&secret.display().to_string()), "data file"),
        ("rel.nhdr", nhdr("../outside/secret.raw"), "data file"),
        ("etc.nhdr", nhdr("/etc/passwd"), "data file"),
    ];
    for (name, text, _) in &cases {
        std::fs::write(scene_dir.join(name), text).unwrap();
    }
    std::fs::write(scene_dir.join("good.mhd"), mhd("data.raw")).unwrap();
    std::fs::write(scene_dir.join("good.nhdr"), nhdr("../allowed/other.raw")).unwrap();
    let allowed = dir.join("allowed");
    let server = Server::start(&file, &["--allow-dir", allowed.to_str().unwrap()]);
    alive(&server);
    let file_field = |name: &str| format!("field = {{source = \"file\", path = \"{name}\"}}");
    for (name, _, key) in &cases {
        let a = server.post("/api/state", &json!({ "set": [file_field(name)] }));
        assert_eq!(a.status, 400, "{name}: {}", a.text());
        let e = a.json()["error"].as_str().unwrap().to_string();
        assert!(e.contains(name) && e.contains(key) && e.contains("--allow-dir"), "{name}: {e}");
        for leak in ["secret", "passwd", "bytes", "SECRET"] {
            assert!(!e.contains(leak), "{name}: `{leak}` in {e}");
        }
    }
    let cells = server.get("/api/slice?axis=z&at=0&format=cells").json();
    assert_eq!(cells["values"][0], json!(0.0), "nothing of the secret reached the field: {cells}");
    for name in ["good.mhd", "good.nhdr"] {
        let a = server.post("/api/state", &json!({ "set": [file_field(name)] }));
        assert_eq!(a.status, 200, "{name}: {}", a.text());
    }
    let cells = server.get("/api/slice?axis=z&at=0&format=cells").json();
    assert_eq!(cells["values"], json!([0.0, 10.0, 20.0, 30.0]), "{cells}");
    alive(&server);
    // The command line reads what its headers name, wherever it is.
    let o = isoview(&["stats", &file, "--set", &file_field("rel.mhd")], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Connections that open and send nothing do not hold the workers: a request beside 60 of
/// them (the cap is 64) is answered at once. Each used to hold a worker for its whole head
/// timeout (5 s, counted from when a worker took it), 8 at a time: 40 s for the 61st.
#[gpu_test]
fn idle_connections_do_not_delay_a_request() {
    let server = small_server();
    alive(&server);
    let idle: Vec<TcpStream> = (0..60).map(|_| TcpStream::connect(&server.addr).unwrap()).collect();
    // Let the server accept them and its workers take them up.
    std::thread::sleep(Duration::from_millis(500));
    let start = Instant::now();
    let a = server.get("/api/stats");
    let took = start.elapsed();
    assert_eq!(a.status, 200, "{}", a.text());
    // 0.4 s measured on 2 cores; the bound leaves room for a loaded machine.
    assert!(took < Duration::from_secs(10), "a request beside 60 idle connections took {took:?}");
    // The idle ones are answered 408 within 5 s of their connection, not of a worker's turn.
    for mut s in idle.into_iter().take(8) {
        s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        assert_eq!(read_answer(&mut s).0, 408);
    }
    assert!(start.elapsed() < Duration::from_secs(12), "408s came after {:?}", start.elapsed());
}

/// `ch` repeated: each channel once, and no more names than there are channels.
#[gpu_test]
fn aov_channels_are_bounded() {
    let server = small_server();
    let a = server.get("/api/aov?ch=Z,Z,N.X,Z");
    assert_eq!(a.status, 200, "{}", a.text());
    assert_eq!(a.header("x-isoview-channels"), "Z,N.X");
    assert_eq!(a.body.len(), 2 * 16 * 16 * 4);
    // A query of 2,000 names (each a plane of the image) is refused before any work.
    let many = vec!["Z"; 2000].join(",");
    let a = server.get(&format!("/api/aov?ch={many}"));
    assert_eq!(a.status, 400, "{} bytes", a.body.len());
    let e = a.json()["error"].as_str().unwrap().to_string();
    assert!(e.contains("2000 channel names") && e.contains("at most"), "{e}");
    alive(&server);
}

/// Two different Content-Lengths frame the body two ways (request smuggling): 400. The same
/// length twice is one framing and is accepted.
#[gpu_test]
fn conflicting_content_lengths_are_refused() {
    let server = small_server();
    let body = r#"{"set": ["image.width=16", "image.height=16"]}"#;
    let post = |lengths: &[usize]| {
        let mut req =
            format!("POST /api/state?token={} HTTP/1.1\r\nHost: {}\r\n", server.token, server.addr);
        for n in lengths {
            req += &format!("Content-Length: {n}\r\n");
        }
        exchange(&server, format!("{req}\r\n{body}").as_bytes())
    };
    let (status, text) = post(&[body.len(), 5]);
    assert_eq!(status, 400, "{text}");
    assert!(text.contains("Content-Length"), "{text}");
    assert_eq!(post(&[5, body.len()]).0, 400);
    assert_eq!(post(&[body.len(), body.len()]).0, 200);
    // A GET that reads no body is refused too: the framing is wrong whatever the route.
    let get = format!(
        "GET /api/stats?token={} HTTP/1.1\r\nHost: {}\r\nContent-Length: 0\r\nContent-Length: 1\r\n\r\n",
        server.token, server.addr
    );
    assert_eq!(exchange(&server, get.as_bytes()).0, 400);
    alive(&server);
}

/// A `.vti` nested too deep: the page is told what the reader said (a nesting limit, with
/// its place), not only that the file cannot be read.
#[gpu_test]
fn the_page_sees_why_a_nested_vti_is_refused() {
    let (dir, file) = path_fixture("serve-nested");
    let depth = 5000;
    let text = format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\">\n{}{}</VTKFile>\n",
        "<SECRET-a>".repeat(depth),
        "</SECRET-a>".repeat(depth)
    );
    std::fs::write(dir.join("scene/deep.vti"), text).unwrap();
    let server = Server::start(&file, &[]);
    let a = server.post(
        "/api/state",
        &json!({ "set": ["field = {source = \"file\", path = \"deep.vti\"}"] }),
    );
    assert_eq!(a.status, 400, "{}", a.text());
    let e = a.json()["error"].as_str().unwrap().to_string();
    assert!(e.contains("deep.vti") && e.contains("nests deeper than 64"), "{e}");
    assert!(e.contains("line 3, column ") && !e.contains("SECRET"), "{e}");
    alive(&server);
}

/// Long-polls whose clients went away give back their places: with every parking place
/// taken and then closed, a new long-poll parks within a few seconds (it used to be refused
/// with 503 until the closed ones' 25 s ran out).
#[gpu_test]
fn closed_long_polls_free_their_places() {
    let server = small_server();
    assert_eq!(server.get("/api/frame").status, 200);
    let generation = server.get("/api/state").json()["generation"].as_u64().unwrap();
    let poll = format!(
        "GET /api/frame?after={generation}&level=full&token={} HTTP/1.1\r\nHost: {}\r\n\r\n",
        server.token, server.addr
    );
    let open_poll = || {
        let mut s = TcpStream::connect(&server.addr).unwrap();
        s.write_all(poll.as_bytes()).unwrap();
        s
    };
    let polls: Vec<TcpStream> = (0..32).map(|_| open_poll()).collect();
    // All 32 places are taken: one more is told to come back.
    std::thread::sleep(Duration::from_millis(500));
    let mut extra = open_poll();
    extra.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    assert_eq!(read_answer(&mut extra).0, 503);
    drop(polls);
    let start = Instant::now();
    let parked = loop {
        assert!(
            start.elapsed() < Duration::from_secs(8),
            "no place freed after {:?}",
            start.elapsed()
        );
        std::thread::sleep(Duration::from_millis(250));
        let mut s = open_poll();
        // Parked: no answer until a newer frame. Refused: 503 at once.
        s.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
        let mut buf = [0u8; 64];
        match s.read(&mut buf) {
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                break s
            }
            Ok(n) => assert!(
                String::from_utf8_lossy(&buf[..n]).contains(" 503 "),
                "{:?}",
                String::from_utf8_lossy(&buf[..n])
            ),
            Err(e) => panic!("{e}"),
        }
    };
    // The parked poll is answered with the next frame.
    server.set(&["image.width=16", "image.height=16", "surface.isovalue=0.1"]);
    let mut parked = parked;
    parked.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    assert_eq!(read_answer(&mut parked).0, 200);
}

/// A token given twice in the query (`?token=bad&token=GOOD`) was judged by the last one:
/// a second token is refused like a wrong one, whichever comes first, and so is a second
/// `X-Isoview-Token` header.
#[gpu_test]
fn a_token_given_twice_is_refused() {
    let server = small_server();
    alive(&server);
    let (good, bad) = (server.token.clone(), "0".repeat(32));
    for query in [
        format!("token={bad}&token={good}"),
        format!("token={good}&token={bad}"),
        format!("token={good}&token={good}"),
    ] {
        let a = server.raw("GET", &format!("/api/state?{query}"), &[], b"");
        assert_eq!(a.status, 403, "{query}: {}", a.text());
        assert!(a.text().contains("token: given more than once"), "{query}: {}", a.text());
    }
    let twice = [("X-Isoview-Token", good.as_str()), ("X-Isoview-Token", bad.as_str())];
    let a = server.raw("GET", "/api/state", &twice, b"");
    assert_eq!(a.status, 403, "{}", a.text());
    let a = server.raw("GET", &format!("/api/state?token={good}"), &twice[1..], b"");
    assert_eq!(a.status, 403, "a query token and a header token: {}", a.text());
    alive(&server);
}

/// A `.nrrd` link to a FIFO: the page is told what the command line says (not a regular
/// file), not "cannot tell the format" (the format was read from the link's target's name);
/// a `.nrrd` link to a NRRD file of another name is read as NRRD, as on the command line.
#[gpu_test]
fn a_data_link_is_judged_by_its_own_name_and_its_target_s_kind() {
    let (dir, file) = path_fixture("serve-fifo-link");
    let scene_dir = dir.join("scene");
    let fifo = scene_dir.join("pipe");
    let _ = std::fs::remove_file(&fifo);
    let c_path = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c_path.as_ptr(), 0o600) }, 0);
    let mut volume =
        b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n".to_vec();
    volume.extend([0u8, 10, 20, 30, 40, 50, 60, 70]);
    std::fs::write(scene_dir.join("volume.data"), &volume).unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
               property float z\nelement face 4\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    std::fs::write(scene_dir.join("mesh.data"), ply).unwrap();
    for (link, target) in [("fifo.nrrd", "pipe"), ("v.nrrd", "volume.data"), ("m.ply", "mesh.data")]
    {
        let _ = std::fs::remove_file(scene_dir.join(link));
        std::os::unix::fs::symlink(target, scene_dir.join(link)).unwrap();
    }
    let server = Server::start(&file, &[]);
    let fifo_field = "field = {source = \"file\", path = \"fifo.nrrd\"}";
    let a = server.post("/api/state", &json!({ "set": [fifo_field] }));
    assert_eq!(a.status, 400, "{}", a.text());
    let e = a.json()["error"].as_str().unwrap().to_string();
    assert!(e.contains("is a FIFO (named pipe), not a data file"), "{e}");
    assert!(!e.contains("cannot tell the format"), "{e}");
    let o = isoview(&["stats", &file, "--set", fifo_field], &[]);
    crate::common::assert_fails(&o, 2, &["is a FIFO (named pipe), not a data file"]);
    let a = server
        .post("/api/state", &json!({ "set": ["field = {source = \"file\", path = \"v.nrrd\"}"] }));
    assert_eq!(a.status, 200, "{}", a.text());
    // A mesh's format (STL, OBJ, PLY) too is told from the name written.
    let mesh_field = "field = {source = \"mesh\", path = \"m.ply\", resolution = 8}";
    let a = server.post("/api/state", &json!({ "set": [mesh_field] }));
    assert_eq!(a.status, 200, "{}", a.text());
    alive(&server);
}

/// A `.npy` header nested too deep: the page is told the reader's limit (positions and
/// numbers only), as for a deep `.vti`, not only that the file cannot be read.
#[gpu_test]
fn the_page_sees_why_a_nested_npy_header_is_refused() {
    let (dir, file) = path_fixture("serve-nested-npy");
    let nest = 5000;
    let dict = format!(
        "{{'descr': '<f4', 'fortran_order': False, 'shape': (2, 2, 2), 'SECRET': {}{}}}\n",
        "[".repeat(nest),
        "]".repeat(nest)
    );
    let mut bytes = b"\x93NUMPY\x02\x00".to_vec();
    bytes.extend((dict.len() as u32).to_le_bytes());
    bytes.extend(dict.as_bytes());
    bytes.extend([0u8; 32]);
    std::fs::write(dir.join("scene/deep.npy"), &bytes).unwrap();
    let server = Server::start(&file, &[]);
    let a = server
        .post("/api/state", &json!({ "set": ["field = {source = \"npy\", path = \"deep.npy\"}"] }));
    assert_eq!(a.status, 400, "{}", a.text());
    let e = a.json()["error"].as_str().unwrap().to_string();
    assert!(e.contains("deep.npy") && e.contains("nests brackets deeper than 16"), "{e}");
    assert!(e.contains("at header byte ") && !e.contains("SECRET"), "{e}");
    alive(&server);
}

/// Fifth attack pass: a whole request queued while the 8 workers were busy (here 8 POSTs
/// whose bodies never come, each holding a worker for the 10 s body deadline) was answered
/// "408 the request head did not arrive in time" when a worker freed: the head's 5 s counted
/// from accept and had passed in the queue. A head waiting in the socket is now read and
/// served; only a turn that reads past the deadline without a whole head gives 408.
#[gpu_test]
fn a_request_queued_behind_busy_workers_is_served() {
    let server = small_server();
    alive(&server);
    let slow: Vec<TcpStream> = (0..8)
        .map(|_| {
            let mut s = TcpStream::connect(&server.addr).unwrap();
            let head = format!(
                "POST /api/state HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Isoview-Token: {}\r\n\
                 Content-Length: 1000\r\n\r\n{{\"set\"",
                server.token
            );
            s.write_all(head.as_bytes()).unwrap();
            s
        })
        .collect();
    std::thread::sleep(Duration::from_millis(500));
    let request = format!(
        "GET /api/stats HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Isoview-Token: {}\r\n\r\n",
        server.token
    );
    let (status, body) = exchange(&server, request.as_bytes());
    assert_eq!(status, 200, "{body}");
    drop(slow);
    alive(&server);
}

/// Fifth attack pass: an unknown `/api/` route was answered 405 ("not supported"), as if the
/// route existed with other methods. 404 for a route that does not exist; 405 only for a known
/// route asked with the wrong method.
#[gpu_test]
fn an_unknown_api_route_is_404_and_a_wrong_method_405() {
    let server = small_server();
    let ask = |line: &str| {
        let request = format!(
            "{line} HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Isoview-Token: {}\r\n\r\n",
            server.token
        );
        exchange(&server, request.as_bytes())
    };
    let (status, body) = ask("GET /api/nosuch");
    assert_eq!(status, 404, "{body}");
    assert!(body.contains("/api/nosuch: no such page"), "{body}");
    assert_eq!(ask("POST /api/").0, 404);
    assert_eq!(ask("GET /api/stats/x").0, 404);
    for line in ["PUT /api/state", "DELETE /", "GET /api/tev", "POST /api/stats"] {
        let (status, body) = ask(line);
        assert_eq!(status, 405, "{line}: {body}");
        assert!(body.contains("not supported"), "{line}: {body}");
    }
}

/// Requests that need the full frame (`/api/exr`, `/api/aov`, a slice picture) wait for it
/// without holding a worker: with more of them waiting on a slow frame than there are
/// workers, the page's other requests are still answered at once. Each used to hold one of
/// the 8 workers until the frame was drawn, so `/api/state` waited for the frame too.
#[gpu_test]
fn frame_waits_leave_the_workers_free() {
    // A first frame of some seconds (384x384, 2,000 fixed steps: 4.5 s at the command line
    // on lavapipe); the server prints its URL before drawing it.
    let (w, h) = (384, 384);
    let server = Server::start(
        &scene("cell-tunnel.toml"),
        &[
            "--set",
            &format!("image.width={w}"),
            "--set",
            &format!("image.height={h}"),
            "--set",
            "render.method=fixed-step",
            "--set",
            "render.steps=2000",
        ],
    );
    let waits = ["/api/exr"; 6]
        .into_iter()
        .chain(["/api/aov?ch=Z,N.X"; 4])
        .chain(["/api/slice?axis=z&at=0.5&format=png"; 2]);
    std::thread::scope(|scope| {
        let waiting = get_each(scope, &server, waits);
        // Let the server take them all up: 12 requests, more than its 8 workers. (The frame
        // takes seconds: 8 s on 2 cores, in bands, beside these requests.)
        std::thread::sleep(Duration::from_millis(200));
        let state = server.get("/api/state");
        let state_at = Instant::now();
        assert_eq!(state.status, 200, "{}", state.text());
        let answers: Vec<_> = waiting.into_iter().map(|t| t.join().unwrap()).collect();
        let first = answers.iter().map(|(_, _, at)| *at).min().unwrap();
        let frame = server.get("/api/frame");
        assert!(
            state_at < first,
            "/api/state was answered {:?} after the first of the requests waiting for the frame \
             (drawn in {} ms)",
            state_at - first,
            frame.header("x-isoview-render-ms")
        );
        // Every waiting request gets the frame once it is drawn: the same EXR as asked now.
        let exr = server.get("/api/exr");
        assert_eq!(exr.status, 200, "{}", exr.text());
        for (path, a, _) in &answers {
            assert_eq!(a.status, 200, "{path}: {}", a.text());
            if path.starts_with("/api/exr") {
                assert_eq!(a.body, exr.body, "{path}: another EXR than the frame's");
            } else if path.starts_with("/api/aov") {
                assert_eq!(a.header("x-isoview-channels"), "Z,N.X");
                assert_eq!(a.body.len(), 2 * w * h * 4, "{path}");
            } else {
                assert_eq!(a.header("content-type"), "image/png", "{path}");
            }
        }
    });
}

/// A `.vti` whose `WholeExtent` goes to 1e300: the reader's arithmetic on it overflowed,
/// a panic in the request's worker (issue 29).
const HUGE_EXTENT_VTI: &str = "<VTKFile type=\"ImageData\" byte_order=\"LittleEndian\">\
    <ImageData WholeExtent=\"0 1e300 0 1 0 1\" Origin=\"0 0 0\" Spacing=\"1 1 1\">\
    <Piece Extent=\"0 1e300 0 1 0 1\"><PointData Scalars=\"s\">\
    <DataArray type=\"Float32\" Name=\"s\" format=\"ascii\">0 1 2 3 4 5 6 7</DataArray>\
    </PointData></Piece></ImageData></VTKFile>";

/// Nine states naming that file, one more than the workers: each panic used to end its
/// worker for good (the client saw its connection closed unanswered), and from the ninth on
/// the server answered nothing. Each must be answered, and the server must go on answering.
/// (A panic now answers 500, `server::survive`; the reader refuses this file, so 400.)
#[gpu_test]
fn requests_that_found_a_bug_leave_every_worker_serving() {
    let (dir, file) = path_fixture("serve-huge-extent");
    std::fs::write(dir.join("scene/huge.vti"), HUGE_EXTENT_VTI).unwrap();
    let server = Server::start(&file, &[]);
    let body = json!({ "set": ["field = {source = \"file\", path = \"huge.vti\"}"] }).to_string();
    let request = format!(
        "POST /api/state HTTP/1.0\r\nHost: {}\r\nX-Isoview-Token: {}\r\nContent-Length: {}\r\n\r\n{body}",
        server.addr,
        server.token,
        body.len()
    );
    for i in 0..9 {
        let (status, answer) = exchange(&server, request.as_bytes());
        assert_eq!(status, 400, "request {i}: {answer}");
        let e: serde_json::Value = serde_json::from_str(&answer).unwrap();
        let e = e["error"].as_str().unwrap();
        assert!(e.contains("huge.vti") && !e.contains('\n') && !e.contains("panicked"), "{e}");
    }
    alive(&server);
}

/// Left by the fourth pass: `GET /api/state`, `/api/probe` and `/api/slice` sampled the field
/// on the request's worker while the render thread had not drawn the latest state, so a
/// costly expression within the 4096-byte limit and a dozen such GETs held all 8 workers
/// (a plain `/api/stats` waited 13-40 s). They now wait, parked, for the field the render
/// thread samples: the cheap request is answered before any of them.
#[gpu_test]
fn requests_for_the_field_leave_the_sampling_to_the_render_thread() {
    let dir = scratch("serve-costly-field");
    // 4095 bytes, one under the cap: ~3 s to sample 48^3 points on one core.
    let sum = vec!["x*y"; 1024].join("+");
    let file = write(
        &dir,
        "costly.toml",
        &format!(
            "[image]\nwidth = 16\nheight = 16\n[field]\nsource = \"expr\"\n\
             expression = \"{sum}\"\nresolution = [48, 48, 48]\n"
        ),
    );
    let server = Server::start(&file, &[]);
    // 16 requests that need the field: two for each worker, so that with sampling on the
    // workers the cheap request below queues behind a second round of them.
    let asks = ["/api/state"; 6]
        .into_iter()
        .chain(["/api/probe?x=8&y=8"; 5])
        .chain(["/api/slice?axis=z&at=20&format=cells"; 5]);
    std::thread::scope(|scope| {
        let waiting = get_each(scope, &server, asks);
        std::thread::sleep(Duration::from_millis(300));
        let mut s = TcpStream::connect(&server.addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(120))).unwrap();
        let get = format!(
            "GET /api/stats?token={} HTTP/1.1\r\nHost: {}\r\n\r\n",
            server.token, server.addr
        );
        s.write_all(get.as_bytes()).unwrap();
        let (status, body) = read_answer(&mut s);
        let stats_at = Instant::now();
        assert_eq!(status, 200, "/api/stats beside 16 requests for a costly field: {body}");
        let answers: Vec<_> = waiting.into_iter().map(|t| t.join().unwrap()).collect();
        let first = answers.iter().map(|(_, _, at)| *at).min().unwrap();
        assert!(
            stats_at < first,
            "/api/stats was answered {:?} after the first request that needed the field",
            stats_at - first
        );
        for (path, a, _) in &answers {
            assert_eq!(a.status, 200, "{path}: {}", a.text());
        }
        let state = answers[0].1.json();
        assert_eq!(state["generation"], 1, "{state}");
        assert!(state["field"]["range"].is_array(), "{state}");
    });
}

/// Fifth pass: `POST /api/state` with `surface.isovalue_sigma` (or `isovalue_percentile`)
/// sampled the whole field on the request's worker to pick the isovalue while the state was
/// validated, so 16 posts of a costly expression held every worker (`/api/stats` waited
/// 20 s); with one load at a time ([`state_loads_are_one_at_a_time`]) the load held its place
/// as long, and every other post was told to ask again. The page's states leave the pick to
/// the render thread, which samples the field anyway: the posts are taken at once, the frame
/// is the command line's, and a pick that gives no isovalue is the frame's 400 with the
/// command line's line.
#[gpu_test]
fn an_isovalue_picked_from_the_samples_is_picked_by_the_render_thread() {
    let server = small_server();
    alive(&server);
    // 4095 bytes, one under the cap: ~3 s to sample 48^3 points on one core.
    let sum = vec!["x*y"; 1024].join("+");
    let costly =
        format!("field = {{source = \"expr\", expression = \"{sum}\", resolution = [48, 48, 48]}}");
    let sets = ["image.width=16", "image.height=16", costly.as_str(), "surface.isovalue_sigma=1"];
    let body = json!({ "set": sets }).to_string();
    let request = format!(
        "POST /api/state HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Isoview-Token: {}\r\n\
         Content-Length: {}\r\n\r\n{body}",
        server.token,
        body.len()
    );
    std::thread::scope(|scope| {
        let posts: Vec<_> =
            (0..16).map(|_| scope.spawn(|| exchange(&server, request.as_bytes()))).collect();
        std::thread::sleep(Duration::from_millis(300));
        let mut s = TcpStream::connect(&server.addr).unwrap();
        // Generous: answered at once now, after 20 s or more when the posts sampled.
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        let get = format!(
            "GET /api/stats HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Isoview-Token: {}\r\n\r\n",
            server.token
        );
        s.write_all(get.as_bytes()).unwrap();
        let (status, body) = read_answer(&mut s);
        assert_eq!(status, 200, "/api/stats beside 16 posts picking a costly isovalue: {body}");
        // The loads no longer sample: a state posted beside them is taken within a second
        // (with the pick in the load, the one load at a time held its place for the field's
        // 3 s of sampling, and this post was told to ask again until then).
        let cheap = json!({ "set": ["image.width=16", "image.height=16"] });
        let started = Instant::now();
        let taken = std::iter::repeat_with(|| server.post("/api/state", &cheap))
            .take_while(|_| started.elapsed() < Duration::from_secs(1))
            .any(|a| a.status == 200);
        assert!(taken, "a post beside 16 that pick a costly isovalue was not taken within 1 s");
        // One state is loaded at a time: the others were told to ask again.
        let statuses: Vec<_> = posts.into_iter().map(|p| p.join().unwrap()).collect();
        assert!(statuses.iter().all(|(s, _)| [200, 503].contains(s)), "{statuses:?}");
        assert!(statuses.iter().any(|(s, _)| *s == 200), "{statuses:?}");
    });

    // The pick is the command line's: the same frame, bit for bit.
    let dir = scratch("serve-picked");
    let file = scene("cell-tunnel.toml");
    let sets = ["image.width=16", "image.height=16", "surface.isovalue_percentile=30"];
    let generation = server.set(&sets);
    let frame = server.get("/api/frame");
    assert_eq!(frame.status, 200, "{}", frame.text());
    assert_eq!(frame.header("x-isoview-generation"), generation.to_string());
    let (_, png) = crate::serve::api::cli_render(&dir, "picked", &file, &sets);
    assert_eq!(frame.body, png, "the frame differs from render --png's");
    let state = server.get("/api/state").json();
    assert_ne!(state["surface"]["isovalue"], 0.0, "{state}");

    // A pick that gives no isovalue: the frame (and the field's requests) answer the line
    // `render` exits 2 with.
    let sets = ["image.width=16", "image.height=16", "surface.isovalue_sigma=1e300"];
    let o = isoview(
        &[
            &["render", &file, "-o", &dir.join("o.exr").display().to_string()][..],
            &["--set", sets[0], "--set", sets[1], "--set", sets[2]],
        ]
        .concat(),
        &[],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let line = stderr(&o).trim_end().to_string();
    assert!(line.contains("surface.isovalue_sigma: gives the isovalue"), "{line}");
    server.set(&sets);
    for path in ["/api/frame", "/api/state"] {
        let a = server.get(path);
        assert_eq!(a.status, 400, "{path}: {}", a.text());
        assert_eq!(a.json()["error"], line.as_str(), "{path}");
    }
}

/// Fifth pass: loading a state reads its volume file whole (a `source = "file"` field is read
/// when the scene loads), on the request's worker. 16 posts naming a 400^3 volume in the
/// scene's folder held every worker for 5 s (`/api/stats` waited as long) and grew the
/// server by 2.4 GB, one grid per worker; at the grid cap that is 8 GiB. One state is loaded
/// at a time: a post beside a load is told to ask again (503, `Retry-After: 1`, as the page
/// does), and memory and workers stay free.
#[gpu_test]
fn state_loads_are_one_at_a_time() {
    let (dir, file) = path_fixture("serve-loads");
    // 400^3 u8 samples (244 MiB of f32 each time it is read).
    let n = 400usize;
    let mut nrrd =
        format!("NRRD0004\ntype: uint8\ndimension: 3\nsizes: {n} {n} {n}\nencoding: raw\n\n")
            .into_bytes();
    nrrd.extend((0..n * n * n).map(|i| (i % 251) as u8));
    std::fs::write(dir.join("scene/v.nrrd"), &nrrd).unwrap();
    let server = Server::start(&file, &["--set", "image.width=16", "--set", "image.height=16"]);
    alive(&server);
    let before = rss_mib(&server);
    let body = json!({ "set": ["image.width=16", "image.height=16",
        "field = {source = \"file\", path = \"v.nrrd\"}"] })
    .to_string();
    let request = format!(
        "POST /api/state HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Isoview-Token: {}\r\n\
         Content-Length: {}\r\n\r\n{body}",
        server.token,
        body.len()
    );
    let peak = std::sync::atomic::AtomicU64::new(0);
    let done = std::sync::atomic::AtomicBool::new(false);
    let statuses = std::thread::scope(|scope| {
        scope.spawn(|| {
            while !done.load(std::sync::atomic::Ordering::Relaxed) {
                let now = status_of(&server, "VmRSS");
                peak.fetch_max(now, std::sync::atomic::Ordering::Relaxed);
                std::thread::sleep(Duration::from_millis(20));
            }
        });
        let posts: Vec<_> =
            (0..16).map(|_| scope.spawn(|| exchange(&server, request.as_bytes()))).collect();
        let statuses: Vec<(u16, String)> = posts.into_iter().map(|p| p.join().unwrap()).collect();
        done.store(true, std::sync::atomic::Ordering::Relaxed);
        statuses
    });
    let grown = peak.into_inner() as f64 / 1024.0 - before;
    for (status, body) in &statuses {
        assert!(*status == 200 || *status == 503, "{status}: {body}");
    }
    assert!(statuses.iter().any(|(s, _)| *s == 200), "{statuses:?}");
    // One load at a time: ~250 MiB (1.9 GB when every worker loaded one).
    assert!(grown < 800.0, "the server grew by {grown:.0} MiB under 16 loads of a 244 MiB grid");
    alive(&server);
}

/// Fifth pass: `GET /api/scene.toml` read the scene file again with a plain read: a scene
/// replaced by a FIFO after the server started held each such request's worker for good
/// (8 requests: every worker; `/api/stats` never answered), and one replaced by a link to
/// `/dev/zero` read without end. It is read as the scene is loaded: a regular file of at
/// most 16 MiB, opened without waiting.
#[gpu_test]
fn the_saved_scene_is_read_as_the_scene_is_loaded() {
    let dir = scratch("serve-scene-fifo");
    let file = write(&dir, "s.toml", "[image]\nwidth = 16\nheight = 16\n[field]\nsource = \"sdf\"\nshape = \"sphere\"\nradius = 0.5\nresolution = [8, 8, 8]\n");
    let server = Server::start(&file, &[]);
    assert_eq!(server.get("/api/scene.toml").status, 200);
    std::fs::remove_file(&file).unwrap();
    let made = std::process::Command::new("mkfifo").arg(&file).status().unwrap();
    assert!(made.success());
    let request = format!(
        "GET /api/scene.toml HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Isoview-Token: {}\r\n\r\n",
        server.token
    );
    std::thread::scope(|scope| {
        let asks: Vec<_> =
            (0..8).map(|_| scope.spawn(|| exchange(&server, request.as_bytes()))).collect();
        for a in asks {
            let (status, body) = a.join().unwrap();
            assert_eq!(status, 500, "{body}");
            assert!(body.contains("is a FIFO (named pipe), not a scene file"), "{body}");
        }
    });
    alive(&server);
    std::fs::remove_file(&file).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &file).unwrap();
    let a = server.get("/api/scene.toml");
    assert_eq!(a.status, 500, "{}", a.text());
    assert!(a.text().contains("is a character device, not a scene file"), "{}", a.text());
}
