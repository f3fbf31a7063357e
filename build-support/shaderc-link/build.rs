//! Debian 12's `libshaderc.so.1` is under-linked (undefined glslang / SPIRV-Tools symbols) and its
//! `libshaderc_combined.a` holds only shaderc itself. isoview's build script therefore links
//! shaderc statically (`prefer-static-linking`, `SHADERC_LIB_DIR` in `.cargo/config.toml`) and
//! this crate adds the static archives that shaderc needs. The build script of the main crate
//! must `use shaderc_link as _;`, or rustc drops this crate and its link directives with it.

fn main() {
    let libdir = std::env::var("SHADERC_LIB_DIR")
        .ok()
        .or_else(|| {
            std::process::Command::new("pkg-config")
                .args(["--variable=libdir", "shaderc"])
                .output()
                .ok()
                .filter(|o| o.status.success())
                .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        })
        .unwrap_or_else(|| "/usr/lib/x86_64-linux-gnu".to_string());
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    println!("cargo:rustc-link-search=native={libdir}");
    for lib in [
        "MachineIndependent",
        "GenericCodeGen",
        "OSDependent",
        "OGLCompiler",
        "SPIRV",
        "SPIRV-Tools-opt",
        "SPIRV-Tools",
    ] {
        println!("cargo:rustc-link-lib=static={lib}");
    }
}
