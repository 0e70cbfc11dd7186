//! Build script: with the `ffi` feature, generate the C++ side of the cxx bridge
//! (src/ffi/mod.rs) and compile it into the library. Headers land in
//! `$CARGO_TARGET_DIR/cxxbridge/` (used by `cpp/Makefile`). Without the feature it does
//! nothing, so the default build needs no C++ compiler.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    #[cfg(feature = "ffi")]
    {
        println!("cargo:rerun-if-changed=src/ffi/mod.rs");
        cxx_build::bridge("src/ffi/mod.rs")
            .std("c++14")
            .compile("anisobond-cxxbridge");
    }
}
