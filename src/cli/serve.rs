//! `isoview serve SCENE.toml [--port P] [--bind ADDR] [--set K=V]... [--time T]`: the
//! interactive page (`crate::serve`).

use std::net::IpAddr;
use std::path::PathBuf;

use super::{Cli, Failure};
use crate::serve::{self, Options, ServeError};

#[derive(clap::Args, Debug)]
pub struct ServeArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// TCP port (0: any free port; the printed URL says which).
    #[arg(long, default_value_t = 8000)]
    pub port: u16,
    /// Address to listen on. The default serves this machine only; reach it from elsewhere
    /// with `ssh -L 8000:127.0.0.1:8000 HOST`.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: IpAddr,
    /// Override a scene key (as for `render`); the page starts from these.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Time of the field in seconds (`t` in expr fields) to start at.
    #[arg(long, default_value_t = 0.0)]
    pub time: f64,
}

pub fn run(cli: &Cli, args: &ServeArgs) -> Result<i32, Failure> {
    // Bad input is reported before the GPU is touched.
    crate::scene::load(&args.scene, &args.sets).map_err(Failure::input)?;
    let ctx = cli.gpu()?;
    let options = Options {
        scene: args.scene.clone(),
        sets: args.sets.clone(),
        time: args.time,
        bind: args.bind,
        port: args.port,
    };
    match serve::run(&options, ctx, &mut std::io::stdout()) {
        Ok(()) => Ok(0),
        Err(ServeError::Input(m)) => Err(Failure::input(m)),
        Err(ServeError::Gpu(m)) => Err(Failure::gpu(m)),
    }
}
