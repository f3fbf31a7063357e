//! `isoview compare A.exr B.exr`: per-channel comparison of two float EXRs (A the reference,
//! B under test), a table on stdout, optional difference EXR and heat-map PNG. The files are
//! read and the outputs written band by band ([`crate::compare::compare_files`]), so memory
//! does not grow with the image.
//!
//! Exit status: 0 pass (or warn), 1 a difference over the thresholds, 2 bad input (a missing
//! or unreadable file, a size or channel mismatch, an output that cannot be written), with one
//! line on stderr. The rules are in [`crate::compare`].

use std::io::Write;
use std::path::PathBuf;

use crate::compare::{
    compare_files, ChannelClass, Outputs, Thresholds, DEFAULT_FAIL, DEFAULT_WARN,
};
use crate::vocab::echo;

/// Arguments of `isoview compare`.
#[derive(Clone, Debug, clap::Args)]
pub struct CompareArgs {
    /// The reference image.
    #[arg(value_name = "A.exr")]
    pub a: PathBuf,
    /// The image compared with it.
    #[arg(value_name = "B.exr")]
    pub b: PathBuf,
    /// Write B − A per channel, a fail mask and the error ratio to this EXR.
    #[arg(long, value_name = "DIFF.exr")]
    pub diff: Option<PathBuf>,
    /// Write a heat map of the differences to this PNG.
    #[arg(long, value_name = "DIFF.png")]
    pub png: Option<PathBuf>,
    /// Absolute difference over which a float value fails (integer channels: exact unless
    /// --fail-class integer=T).
    #[arg(long, allow_hyphen_values = true, value_name = "T", default_value_t = DEFAULT_FAIL, value_parser = non_negative)]
    pub fail: f64,
    /// Percentage of pixels allowed to fail.
    #[arg(long, allow_hyphen_values = true, value_name = "P", default_value_t = 0.0, value_parser = non_negative)]
    pub fail_percent: f64,
    /// Relative threshold: a value fails only when its difference is also over
    /// R * max(|a|, |b|).
    #[arg(long, allow_hyphen_values = true, value_name = "R", default_value_t = 0.0, value_parser = non_negative)]
    pub fail_relative: f64,
    /// Fail if any value differs by more than H, whatever the percentage.
    #[arg(long, allow_hyphen_values = true, value_name = "H", value_parser = non_negative)]
    pub hard_fail: Option<f64>,
    /// Fail threshold for one channel class: colour, depth, normal, position, integer, other
    /// (repeatable).
    #[arg(long, value_name = "CLASS=T", value_parser = class_threshold)]
    pub fail_class: Vec<(ChannelClass, f64)>,
    /// Absolute difference over which a value warns.
    #[arg(long, allow_hyphen_values = true, value_name = "T", default_value_t = DEFAULT_WARN, value_parser = non_negative)]
    pub warn: f64,
    /// Percentage of pixels allowed over the warn threshold before the verdict is WARN.
    #[arg(long, allow_hyphen_values = true, value_name = "P", default_value_t = 0.0, value_parser = non_negative)]
    pub warn_percent: f64,
    /// Forgive failing pixels where a silhouette moved by one pixel.
    #[arg(long)]
    pub shift: bool,
    /// Do not compute the FLIP figure of the beauty.
    #[arg(long, conflicts_with = "flip_fail")]
    pub no_flip: bool,
    /// Fail when the FLIP mean of the beauty is over this.
    #[arg(long, allow_hyphen_values = true, value_name = "MEAN", value_parser = non_negative)]
    pub flip_fail: Option<f64>,
    /// Compare only these channels (comma-separated); others may differ between the files.
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub channels: Vec<String>,
    /// Accept channels only B has (e.g. a channel added since A was made): they are named in
    /// a note and not compared; the channels both have are. Without it such files are a
    /// channel mismatch (exit 2).
    #[arg(long, conflicts_with = "channels")]
    pub new_channels: bool,
}

fn non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v >= 0.0 => Ok(v),
        _ => Err(format!("\"{}\" is not a number ≥ 0", echo(s))),
    }
}

fn class_threshold(s: &str) -> Result<(ChannelClass, f64), String> {
    let (class, value) =
        s.split_once('=').ok_or_else(|| format!("\"{}\" is not CLASS=T", echo(s)))?;
    let class = ChannelClass::parse(class.trim()).ok_or_else(|| {
        format!(
            "unknown channel class \"{}\" (colour, depth, normal, position, integer, other)",
            echo(class)
        )
    })?;
    Ok((class, non_negative(value.trim())?))
}

impl CompareArgs {
    /// The thresholds these arguments ask for.
    pub fn thresholds(&self) -> Thresholds {
        Thresholds {
            fail: self.fail,
            fail_class: self.fail_class.clone(),
            fail_relative: self.fail_relative,
            fail_percent: self.fail_percent,
            hard_fail: self.hard_fail,
            warn: self.warn,
            warn_percent: self.warn_percent,
            shift: self.shift,
            flip: !self.no_flip,
            flip_fail: self.flip_fail,
            only: (!self.channels.is_empty()).then(|| self.channels.clone()),
            new_channels: self.new_channels,
        }
    }
}

/// Runs the command, printing to `out` (the report) and `err` (a refusal); returns the exit
/// status.
pub fn run_with(args: &CompareArgs, out: &mut dyn Write, err: &mut dyn Write) -> i32 {
    let fail = |err: &mut dyn Write, e: &dyn std::fmt::Display| {
        // Nothing better to do when stderr itself is gone.
        let _ = writeln!(err, "isoview: {e}");
        2
    };
    let inputs = [("A", args.a.as_path()), ("B", args.b.as_path())];
    let outputs: Vec<(&str, &std::path::Path)> = [("--diff", &args.diff), ("--png", &args.png)]
        .into_iter()
        .filter_map(|(flag, p)| Some((flag, p.as_deref()?)))
        .collect();
    if let Err(e) = crate::output::guard::check(&outputs, &inputs) {
        return fail(err, &e);
    }
    let outputs = Outputs { diff: args.diff.as_deref(), png: args.png.as_deref() };
    let (report, output_error) = match compare_files(&args.a, &args.b, &args.thresholds(), outputs)
    {
        Ok(r) => r,
        Err(e) => return fail(err, &e),
    };
    // A reader that has gone leaves the verdict's status; any other failure (a full disk)
    // is one line and exit 2, as for every verb (console's rule).
    let written = write!(out, "{report}").and_then(|()| out.flush());
    if let Some(line) = written.err().as_ref().and_then(super::console::stdout_failure) {
        return fail(err, &line);
    }
    if let Some(e) = output_error {
        return fail(err, &e);
    }
    report.verdict.exit_code()
}
