//! The `isoview` binary: everything lives in the library; see `isoview::cli`.

fn main() {
    std::process::exit(isoview::cli::main());
}
