//! Compiles the C++ side of the bridge (cpp/bridge.cpp) against Debian's OpenVDB 10
//! (`libopenvdb-dev`; its headers need `libboost-dev` and `libtbb-dev`, which `./x` installs)
//! and links libopenvdb, libtbb and Imath (OpenVDB's half floats). Debian ships no pkg-config
//! file for OpenVDB, so the libraries are named directly; OPENVDB_INCLUDE_DIR and
//! OPENVDB_LIB_DIR point elsewhere.

fn main() {
    println!("cargo:rerun-if-changed=cpp/bridge.cpp");
    println!("cargo:rerun-if-env-changed=OPENVDB_INCLUDE_DIR");
    println!("cargo:rerun-if-env-changed=OPENVDB_LIB_DIR");
    let mut build = cc::Build::new();
    build.cpp(true).std("c++17").file("cpp/bridge.cpp").warnings(false);
    // OpenVDB's headers are heavy: the bridge is small, -O1 keeps its compile near 10 s.
    build.opt_level(1);
    if let Ok(dir) = std::env::var("OPENVDB_INCLUDE_DIR") {
        build.include(dir);
    }
    build.compile("isoview_openvdb_bridge");
    if let Ok(dir) = std::env::var("OPENVDB_LIB_DIR") {
        println!("cargo:rustc-link-search=native={dir}");
    }
    for lib in ["openvdb", "tbb", "Imath"] {
        println!("cargo:rustc-link-lib={lib}");
    }
}
