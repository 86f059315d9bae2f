//! The `compare` benchmark links intel_tex_2, whose ASTC part is C++ and needs the C++
//! runtime, which intel_tex_2 does not link itself. Only the benchmarks get it: the library,
//! tests and everything that depends on ori-texture stay free of C++.

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let env = std::env::var("CARGO_CFG_TARGET_ENV").unwrap_or_default();
    let runtime = match (os.as_str(), env.as_str()) {
        ("macos" | "ios", _) => Some("c++"),
        (_, "msvc") => None, // the MSVC linker finds its C++ runtime itself
        _ => Some("stdc++"),
    };
    if let Some(lib) = runtime {
        println!("cargo::rustc-link-arg-benches=-l{lib}");
    }
}
