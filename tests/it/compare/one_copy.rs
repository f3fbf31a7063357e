//! One copy of each (issue #24 item 5): the whole-image `compare` (report, difference EXR,
//! heat map) and the in-memory EXR writers (`encode_frame`, `write_channels`) are the streamed
//! code run with one band. The fingerprints below were recorded from the separate whole-image
//! and in-memory code before it was deleted: the one-band path must reproduce its reports and
//! files byte for byte, on images of several sizes, layouts and threshold options.

use std::path::{Path, PathBuf};

use isoview::compare::{compare, write_diff_exr, write_heat_map_png, Thresholds};
use isoview::output::exr as out_exr;

use crate::cli::output::test_frame;
use crate::common::{self, assert_fingerprints, scratch};
use crate::compare::stream::{picture, write, Layout};

fn fnv(bytes: &[u8]) -> u64 {
    common::fnv(common::FNV_START, bytes)
}

fn file_fnv(path: &Path) -> u64 {
    fnv(&std::fs::read(path).unwrap())
}

/// Every output of the whole-image and in-memory API on the test inputs, fingerprinted.
fn outcomes(dir: &Path) -> Vec<(String, u64)> {
    let mut out = Vec::new();
    let variants: Vec<(&str, Thresholds)> = vec![
        ("default", Thresholds::default()),
        ("shift", Thresholds { shift: true, ..Thresholds::default() }),
        (
            "relative, hard, percentages, no FLIP",
            Thresholds {
                fail_relative: 1e-3,
                hard_fail: Some(0.3),
                fail_percent: 2.0,
                warn_percent: 5.0,
                flip: false,
                ..Thresholds::default()
            },
        ),
        ("flip gate", Thresholds { flip_fail: Some(0.01), shift: true, ..Thresholds::default() }),
    ];
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    let (diff, png) = (dir.join("diff.exr"), dir.join("diff.png"));
    for (w, h) in [(37, 41), (16, 32), (1, 7), (9, 1)] {
        for layout in [Layout::Isoview, Layout::HalfTiles] {
            write(&a, w, h, &picture(w, h, false), layout);
            write(&b, w, h, &picture(w, h, true), layout);
            // Fixed names: the report and the difference EXR's header carry the paths.
            let read = |p: &Path, name: &str| {
                let mut image = out_exr::read(p).unwrap();
                image.path = PathBuf::from(name);
                image
            };
            let (ia, ib) = (read(&a, "a.exr"), read(&b, "b.exr"));
            let mut cases: Vec<(&str, &Thresholds, bool)> =
                variants.iter().map(|(n, t)| (*n, t, false)).collect();
            cases.push(("same", &variants[0].1, true));
            for (name, t, same) in cases {
                let other = if same { &ia } else { &ib };
                let r = compare(&ia, other, t).unwrap();
                let what = format!("{w}x{h} {layout:?} {name}");
                // Debug prints every float exactly, and the per-pixel maps.
                out.push((format!("{what}: report"), fnv(format!("{r:?}\n{r}").as_bytes())));
                write_diff_exr(&diff, &ia, other, &r).unwrap();
                out.push((format!("{what}: diff EXR"), file_fnv(&diff)));
                write_heat_map_png(&png, &r).unwrap();
                out.push((format!("{what}: heat map"), file_fnv(&png)));
            }
        }
    }
    let frame_file = dir.join("frame.exr");
    for (w, h) in [(1, 1), (3, 2), (16, 16), (17, 33), (64, 40)] {
        let frame = test_frame(w, h);
        let bytes = out_exr::encode_frame(&frame_file, &frame).unwrap();
        out_exr::write_frame(&frame_file, &frame).unwrap();
        assert!(std::fs::read(&frame_file).unwrap() == bytes, "{w}x{h}: write_frame");
        out.push((format!("frame {w}x{h}"), fnv(&bytes)));
    }
    let planes = dir.join("planes.exr");
    for (w, h) in [(1, 1), (5, 17), (37, 41)] {
        let attributes = [("isoview/test".to_string(), format!("{w}x{h}"))];
        out_exr::write_channels(&planes, w, h, picture(w, h, true), &attributes).unwrap();
        out.push((format!("channels {w}x{h}"), file_fnv(&planes)));
    }
    out
}

#[test]
fn the_one_band_path_reproduces_the_former_whole_image_outputs() {
    let dir = scratch("one-copy");
    let got = outcomes(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_fingerprints(&got, EXPECTED, "the former code's outputs");
}

/// Recorded from the separate whole-image compare and in-memory EXR writers (before #24.5).
const EXPECTED: &[(&str, u64)] = &[
    ("37x41 Isoview default: report", 0xcef13955fec4ebff),
    ("37x41 Isoview default: diff EXR", 0xe16f2e28d7559533),
    ("37x41 Isoview default: heat map", 0x28e4f314253af6ec),
    ("37x41 Isoview shift: report", 0x7bbac3710b371694),
    ("37x41 Isoview shift: diff EXR", 0x9a25d69321cb7a13),
    ("37x41 Isoview shift: heat map", 0x15895e1fc4e03b94),
    ("37x41 Isoview relative, hard, percentages, no FLIP: report", 0x8651124aceb7ac89),
    ("37x41 Isoview relative, hard, percentages, no FLIP: diff EXR", 0xe7b29f395b0b4a0c),
    ("37x41 Isoview relative, hard, percentages, no FLIP: heat map", 0x2c9a6f79082526b8),
    ("37x41 Isoview flip gate: report", 0x0ebaf91bd0ca850c),
    ("37x41 Isoview flip gate: diff EXR", 0x0ca6e67097a8b181),
    ("37x41 Isoview flip gate: heat map", 0x15895e1fc4e03b94),
    ("37x41 Isoview same: report", 0x74f058866f555364),
    ("37x41 Isoview same: diff EXR", 0x3ae79bbe2364a037),
    ("37x41 Isoview same: heat map", 0xe5f73c7a1be45faa),
    ("37x41 HalfTiles default: report", 0xeaab985c15bafd84),
    ("37x41 HalfTiles default: diff EXR", 0x6527253669758e10),
    ("37x41 HalfTiles default: heat map", 0x3ee3f968ab00c28d),
    ("37x41 HalfTiles shift: report", 0xad66330706df090d),
    ("37x41 HalfTiles shift: diff EXR", 0x9143f62c02d7c710),
    ("37x41 HalfTiles shift: heat map", 0x771aca35d28c916f),
    ("37x41 HalfTiles relative, hard, percentages, no FLIP: report", 0x3cf43401c3cc0fe2),
    ("37x41 HalfTiles relative, hard, percentages, no FLIP: diff EXR", 0x65b78beccb212432),
    ("37x41 HalfTiles relative, hard, percentages, no FLIP: heat map", 0xe2eae30c9fe551bb),
    ("37x41 HalfTiles flip gate: report", 0x8d83a79f3131042d),
    ("37x41 HalfTiles flip gate: diff EXR", 0xfa08db900859e922),
    ("37x41 HalfTiles flip gate: heat map", 0x771aca35d28c916f),
    ("37x41 HalfTiles same: report", 0x74f058866f555364),
    ("37x41 HalfTiles same: diff EXR", 0x3ae79bbe2364a037),
    ("37x41 HalfTiles same: heat map", 0xe5f73c7a1be45faa),
    ("16x32 Isoview default: report", 0x72c4e3ddb4ab721c),
    ("16x32 Isoview default: diff EXR", 0x88e405cb3ff3c6d1),
    ("16x32 Isoview default: heat map", 0x54858de40949ceac),
    ("16x32 Isoview shift: report", 0xa71074fcf0d833f1),
    ("16x32 Isoview shift: diff EXR", 0x16007ac61b9214dc),
    ("16x32 Isoview shift: heat map", 0x3e168b018b96304b),
    ("16x32 Isoview relative, hard, percentages, no FLIP: report", 0xf9a25ec24e14cefa),
    ("16x32 Isoview relative, hard, percentages, no FLIP: diff EXR", 0x30f59bca901349ac),
    ("16x32 Isoview relative, hard, percentages, no FLIP: heat map", 0xd72917f828f5aec1),
    ("16x32 Isoview flip gate: report", 0xe38a544876059ce3),
    ("16x32 Isoview flip gate: diff EXR", 0x9eada69806b22023),
    ("16x32 Isoview flip gate: heat map", 0x3e168b018b96304b),
    ("16x32 Isoview same: report", 0x0e67bdbeca788ba2),
    ("16x32 Isoview same: diff EXR", 0x30c9eb4ffe43cb6b),
    ("16x32 Isoview same: heat map", 0x2b9aab29ce1245ab),
    ("16x32 HalfTiles default: report", 0x06c8ee2ad6ed21d1),
    ("16x32 HalfTiles default: diff EXR", 0xc314f40d773969ff),
    ("16x32 HalfTiles default: heat map", 0xa69424e0f0d359bb),
    ("16x32 HalfTiles shift: report", 0x27d3d905d4fa7847),
    ("16x32 HalfTiles shift: diff EXR", 0xcaca68fb4f7f5436),
    ("16x32 HalfTiles shift: heat map", 0x554b3509a11569bc),
    ("16x32 HalfTiles relative, hard, percentages, no FLIP: report", 0x5fe5b4bad347e1df),
    ("16x32 HalfTiles relative, hard, percentages, no FLIP: diff EXR", 0x91f0e316fd4ae814),
    ("16x32 HalfTiles relative, hard, percentages, no FLIP: heat map", 0x40d23a8fc5fdd795),
    ("16x32 HalfTiles flip gate: report", 0x4821d73be03feedd),
    ("16x32 HalfTiles flip gate: diff EXR", 0xa6564a59314ccc22),
    ("16x32 HalfTiles flip gate: heat map", 0x554b3509a11569bc),
    ("16x32 HalfTiles same: report", 0x0e67bdbeca788ba2),
    ("16x32 HalfTiles same: diff EXR", 0x30c9eb4ffe43cb6b),
    ("16x32 HalfTiles same: heat map", 0x2b9aab29ce1245ab),
    ("1x7 Isoview default: report", 0xdcadf0c89ded0c9a),
    ("1x7 Isoview default: diff EXR", 0x02fac7d337bc4028),
    ("1x7 Isoview default: heat map", 0x3662c7193665ff65),
    ("1x7 Isoview shift: report", 0xfaa8fa1a8a0a6d02),
    ("1x7 Isoview shift: diff EXR", 0xc5a17b8eb410a1d1),
    ("1x7 Isoview shift: heat map", 0x3662c7193665ff65),
    ("1x7 Isoview relative, hard, percentages, no FLIP: report", 0x1df01b24e1cc209b),
    ("1x7 Isoview relative, hard, percentages, no FLIP: diff EXR", 0x10b2b9ddb3518420),
    ("1x7 Isoview relative, hard, percentages, no FLIP: heat map", 0x3662c7193665ff65),
    ("1x7 Isoview flip gate: report", 0x50bc483f038192ee),
    ("1x7 Isoview flip gate: diff EXR", 0x001116cf1c0653cf),
    ("1x7 Isoview flip gate: heat map", 0x3662c7193665ff65),
    ("1x7 Isoview same: report", 0xad5f2401e8477138),
    ("1x7 Isoview same: diff EXR", 0x36ede80a078e05b7),
    ("1x7 Isoview same: heat map", 0x0d62becdb56da6fd),
    ("1x7 HalfTiles default: report", 0x288790b7e3beb81e),
    ("1x7 HalfTiles default: diff EXR", 0x189ee7824e70641f),
    ("1x7 HalfTiles default: heat map", 0xe612ae7185eb431e),
    ("1x7 HalfTiles shift: report", 0x2728465066cae44c),
    ("1x7 HalfTiles shift: diff EXR", 0x3a2108279c802b1b),
    ("1x7 HalfTiles shift: heat map", 0xe612ae7185eb431e),
    ("1x7 HalfTiles relative, hard, percentages, no FLIP: report", 0x456e3f6d1aa6ee73),
    ("1x7 HalfTiles relative, hard, percentages, no FLIP: diff EXR", 0x2ad7b64bd70b09fe),
    ("1x7 HalfTiles relative, hard, percentages, no FLIP: heat map", 0xe612ae7185eb431e),
    ("1x7 HalfTiles flip gate: report", 0x798e52f37e468f24),
    ("1x7 HalfTiles flip gate: diff EXR", 0xf1dbfa134f977e61),
    ("1x7 HalfTiles flip gate: heat map", 0xe612ae7185eb431e),
    ("1x7 HalfTiles same: report", 0xad5f2401e8477138),
    ("1x7 HalfTiles same: diff EXR", 0x36ede80a078e05b7),
    ("1x7 HalfTiles same: heat map", 0x0d62becdb56da6fd),
    ("9x1 Isoview default: report", 0xd79244b2730fe644),
    ("9x1 Isoview default: diff EXR", 0xacd0a924b18329c4),
    ("9x1 Isoview default: heat map", 0x004c7217d4d4d25b),
    ("9x1 Isoview shift: report", 0xbc3c4c149786ead0),
    ("9x1 Isoview shift: diff EXR", 0x94ac4c2dd0345e23),
    ("9x1 Isoview shift: heat map", 0x81518205141347aa),
    ("9x1 Isoview relative, hard, percentages, no FLIP: report", 0x2091cace6035b6e1),
    ("9x1 Isoview relative, hard, percentages, no FLIP: diff EXR", 0x7f3b3aba397055c2),
    ("9x1 Isoview relative, hard, percentages, no FLIP: heat map", 0x004c7217d4d4d25b),
    ("9x1 Isoview flip gate: report", 0x1a78d3de56682a36),
    ("9x1 Isoview flip gate: diff EXR", 0x986f92d2648f2b7b),
    ("9x1 Isoview flip gate: heat map", 0x81518205141347aa),
    ("9x1 Isoview same: report", 0x6262ae819115fce6),
    ("9x1 Isoview same: diff EXR", 0xfdfeeee58b87d638),
    ("9x1 Isoview same: heat map", 0xeb52384dfe14cb54),
    ("9x1 HalfTiles default: report", 0x815f1633ff660a38),
    ("9x1 HalfTiles default: diff EXR", 0x289ca45273baeac9),
    ("9x1 HalfTiles default: heat map", 0xeae5734ed6d63698),
    ("9x1 HalfTiles shift: report", 0xfb9dda494b7bd254),
    ("9x1 HalfTiles shift: diff EXR", 0x0902aa79005cb38a),
    ("9x1 HalfTiles shift: heat map", 0xb61c16a18ed2c257),
    ("9x1 HalfTiles relative, hard, percentages, no FLIP: report", 0x36a30a6d3e970bcc),
    ("9x1 HalfTiles relative, hard, percentages, no FLIP: diff EXR", 0x89662408872805be),
    ("9x1 HalfTiles relative, hard, percentages, no FLIP: heat map", 0xeae5734ed6d63698),
    ("9x1 HalfTiles flip gate: report", 0xbe22e0bd0f3a2036),
    ("9x1 HalfTiles flip gate: diff EXR", 0x007c0090101a4912),
    ("9x1 HalfTiles flip gate: heat map", 0xb61c16a18ed2c257),
    ("9x1 HalfTiles same: report", 0x6262ae819115fce6),
    ("9x1 HalfTiles same: diff EXR", 0xfdfeeee58b87d638),
    ("9x1 HalfTiles same: heat map", 0xeb52384dfe14cb54),
    ("frame 1x1", 0x7ae3e45d92e97fe8),
    ("frame 3x2", 0x4361371c94f270b6),
    ("frame 16x16", 0x5c62e222ccf8fed8),
    ("frame 17x33", 0xb81d47136f1f88cb),
    ("frame 64x40", 0x6baac5ec0888a6ef),
    ("channels 1x1", 0xcdd105bc459767d6),
    ("channels 5x17", 0x2b457dcede97a397),
    ("channels 37x41", 0x0daa98d6aa7638a9),
];
