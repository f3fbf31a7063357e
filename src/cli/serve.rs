//! `isoview serve SCENE.toml [--port P] [--bind ADDR] [--set K=V]... [--time T]
//! [--allow-dir DIR]... [--max-pixels N]`: the interactive page (`crate::serve`).

use std::net::IpAddr;
use std::path::PathBuf;

use super::{Cli, Failure};
use crate::serve::{self, Options, ServeError};

#[derive(clap::Args, Debug)]
pub struct ServeArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// TCP port (0: any free port; the printed URL says which).
    #[arg(long, allow_hyphen_values = true, default_value_t = 8000)]
    pub port: u16,
    /// Address to listen on. The default serves this machine only; reach it from elsewhere
    /// with `ssh -L 8000:127.0.0.1:8000 HOST`.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: IpAddr,
    /// Override a scene key (as for `render`); the page starts from these.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Time of the field in seconds (`t` in expr fields) to start at.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = super::number)]
    pub time: f64,
    /// A folder whose files the page may point the field at, besides the scene's folder and
    /// the scene's own data files (repeatable).
    #[arg(long = "allow-dir", value_name = "DIR")]
    pub allow_dirs: Vec<PathBuf>,
    /// Largest image, in pixels (width x height), the page may ask for.
    #[arg(long, allow_hyphen_values = true, value_name = "N", default_value_t = crate::scene::DEFAULT_MAX_PIXELS,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub max_pixels: u64,
}

pub fn run(cli: &Cli, args: &ServeArgs) -> Result<i32, Failure> {
    let options = Options {
        scene: args.scene.clone(),
        sets: args.sets.clone(),
        time: args.time,
        bind: args.bind,
        port: args.port,
        allow_dirs: args.allow_dirs.clone(),
        max_pixels: args.max_pixels,
    };
    // Bad input is reported before the GPU is touched.
    serve::prepare(&options).map_err(|e| Failure::input(e.to_string()))?;
    let ctx = cli.gpu()?;
    match serve::run(&options, ctx, &mut std::io::stdout()) {
        Ok(()) => Ok(0),
        Err(ServeError::Input(m)) => Err(Failure::input(m)),
        Err(ServeError::Gpu(m)) => Err(Failure::gpu(m)),
    }
}
