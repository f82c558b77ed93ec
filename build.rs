//! Generates Rust bindings for Debian's Embree 3 with bindgen and links `libembree3`.
//!
//! Search order for Embree: `$EMBREE_DIR/{include,lib}` if set, then the system
//! include and library paths. Anything missing stops the build with one sentence
//! naming the package to install, instead of a page of clang errors.

use std::env;
use std::path::{Path, PathBuf};

const INSTALL_HINT: &str = "install it with `sudo apt-get install libembree-dev libclang-dev` \
(or `./dev.sh deps`), or point EMBREE_DIR at an Embree 3 installation";

/// Stops the build with one sentence, shown by cargo as an error (no backtrace).
fn fail(message: &str) -> ! {
    println!("cargo::error={message}");
    std::process::exit(1);
}

fn system_include_dirs() -> Vec<PathBuf> {
    ["/usr/include", "/usr/local/include"].iter().map(PathBuf::from).collect()
}

fn system_lib_dirs() -> Vec<PathBuf> {
    ["/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64", "/usr/lib", "/usr/local/lib"]
        .iter()
        .map(PathBuf::from)
        .collect()
}

fn find_dir(dirs: &[PathBuf], relative: &str) -> Option<PathBuf> {
    dirs.iter().find(|d| d.join(relative).exists()).cloned()
}

fn main() {
    println!("cargo:rerun-if-changed=vendor-headers/embree3_wrapper.h");
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");

    let (include_dirs, lib_dirs) = match env::var_os("EMBREE_DIR") {
        Some(root) => {
            let root = PathBuf::from(root);
            (vec![root.join("include")], vec![root.join("lib"), root.join("lib64")])
        }
        None => (system_include_dirs(), system_lib_dirs()),
    };

    let Some(include_dir) = find_dir(&include_dirs, "embree3/rtcore.h") else {
        fail(&format!(
            "caustix needs Embree 3's headers (embree3/rtcore.h was not found in {include_dirs:?}); {INSTALL_HINT}"
        ));
    };
    let Some(lib_dir) = find_dir(&lib_dirs, "libembree3.so") else {
        fail(&format!(
            "caustix needs Embree 3's library (libembree3.so was not found in {lib_dirs:?}); {INSTALL_HINT}"
        ));
    };
    // bindgen loads libclang at run time and panics with a long message when it is absent.
    if !libclang_available() {
        fail(&format!(
            "caustix generates its Embree bindings with bindgen, which needs libclang; {INSTALL_HINT}"
        ));
    }

    println!("cargo:rustc-link-search=native={}", lib_dir.display());
    println!("cargo:rustc-link-lib=dylib=embree3");

    let bindings = bindgen::Builder::default()
        .header("vendor-headers/embree3_wrapper.h")
        .clang_arg(format!("-I{}", include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .default_enum_style(bindgen::EnumVariation::Consts)
        .prepend_enum_name(false)
        .layout_tests(false)
        .derive_default(true)
        .generate()
        .unwrap_or_else(|e| {
            fail(&format!(
                "bindgen could not read Embree 3's headers in {} ({e}); {INSTALL_HINT}",
                include_dir.display()
            ))
        });
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    bindings.write_to_file(out.join("embree3_bindings.rs")).expect("OUT_DIR is writable");
}

/// Whether a libclang shared library can be found where bindgen (clang-sys) looks.
fn libclang_available() -> bool {
    if let Some(dir) = env::var_os("LIBCLANG_PATH") {
        return Path::new(&dir).exists();
    }
    let mut dirs = system_lib_dirs();
    for version in (6..=30).rev() {
        dirs.push(PathBuf::from(format!("/usr/lib/llvm-{version}/lib")));
    }
    dirs.iter().any(|d| {
        std::fs::read_dir(d).is_ok_and(|entries| {
            entries.flatten().any(|e| e.file_name().to_string_lossy().starts_with("libclang"))
        })
    })
}
