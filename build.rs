//! Links Embree: by default Embree 3 (Debian 12's `libembree-dev`), with
//! bindings generated here by bindgen; with the `embree4` feature Embree 4
//! (Debian 13's and Ubuntu 24.04's `libembree-dev`), with the bindings of the
//! `embree4-sys` crate.
//!
//! Search order for the library: `$EMBREE_DIR/{include,lib}` if set (then the
//! binaries also get `$EMBREE_DIR/lib` as their run-time search path), else
//! the system include and library paths. Anything missing stops the build
//! with one sentence saying what to install, instead of a page of linker or
//! clang errors.
//!
//! With the `denoise` feature it also checks for Intel Open Image Denoise
//! (the `oidn` crate links it): `$OIDN_DIR/lib` (then the binaries get it as
//! their run-time search path), else the system library paths.

use std::env;
use std::path::{Path, PathBuf};

const INSTALL_HINT: &str = "install it with `sudo apt-get install libembree-dev libclang-dev` \
(or `./dev.sh deps`), or point EMBREE_DIR at an Embree 3 installation";

const INSTALL_HINT_4: &str =
    "on Debian 13 or Ubuntu 24.04 `sudo apt-get install libembree-dev` installs it; \
to test on a system without it, `scripts/embree4-from-wheel.sh` unpacks Embree 4 from PyPI into \
target/embree4 (then set EMBREE_DIR=target/embree4)";

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

/// Where to look for headers and libraries.
fn search_dirs() -> (Vec<PathBuf>, Vec<PathBuf>) {
    match env::var_os("EMBREE_DIR") {
        Some(root) => {
            let root = PathBuf::from(root);
            (vec![root.join("include")], vec![root.join("lib"), root.join("lib64")])
        }
        None => (system_include_dirs(), system_lib_dirs()),
    }
}

/// Links `lib_dir/lib{name}.so`; outside the system folders, binaries also
/// look there at run time.
fn link(lib_dir: &Path, name: &str) {
    println!("cargo:rustc-link-search=native={}", lib_dir.display());
    println!("cargo:rustc-link-lib=dylib={name}");
    if env::var_os("EMBREE_DIR").is_some() {
        let absolute = lib_dir.canonicalize().unwrap_or_else(|_| lib_dir.to_path_buf());
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", absolute.display());
    }
}

/// The `embree4` feature: the bindings come from `embree4-sys`; find and link the library.
fn embree4() {
    let (_, lib_dirs) = search_dirs();
    let Some(lib_dir) = find_dir(&lib_dirs, "libembree4.so") else {
        let other = find_dir(&lib_dirs, "libembree3.so").map_or(String::new(), |d| {
            format!(
                " This system has Embree 3 ({}): build without `--features embree4` to use it.",
                d.join("libembree3.so").display()
            )
        });
        fail(&format!(
            "the embree4 feature needs Embree 4's library (libembree4.so was not found in {lib_dirs:?}); \
             {INSTALL_HINT_4}.{other}"
        ));
    };
    link(&lib_dir, "embree4");
}

const OIDN_HINT: &str = "install Intel's release archive of Open Image Denoise 2.x \
(oidn-2.x.x.x86_64.linux.tar.gz) and set OIDN_DIR to the absolute path of the folder it unpacks to; \
or, for testing, run `scripts/oidn-from-wheel.sh`, which unpacks it into target/oidn, where the build \
looks by default; or build without `--features denoise`";

/// The `denoise` feature: Open Image Denoise must be in `$OIDN_DIR/lib`
/// (`.cargo/config.toml` sets target/oidn unless the caller set another) or
/// in the system library folders, or the `oidn` crate's link fails with a
/// page of linker errors.
fn denoise() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    let root = env::var_os("OIDN_DIR").filter(|d| !d.is_empty()).map(PathBuf::from);
    if let Some(root) = root.as_ref().filter(|r| r.is_relative()) {
        fail(&format!(
            "OIDN_DIR must be an absolute path (the oidn crate reads it from its own folder), found `{}`",
            root.display()
        ));
    }
    let own = root.as_ref().map_or(vec![], |r| vec![r.join("lib"), r.join("lib64")]);
    if let Some(lib_dir) = find_dir(&own, "libOpenImageDenoise.so") {
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
    } else if find_dir(&system_lib_dirs(), "libOpenImageDenoise.so").is_none() {
        fail(&format!(
            "the denoise feature needs Intel Open Image Denoise 2.x (libOpenImageDenoise.so was not found \
             in {:?}); {OIDN_HINT}",
            [own, system_lib_dirs()].concat()
        ));
    }
}

fn main() {
    if env::var_os("CARGO_FEATURE_DENOISE").is_some() {
        denoise();
    }
    println!("cargo:rerun-if-changed=vendor-headers/embree3_wrapper.h");
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    if env::var_os("CARGO_FEATURE_EMBREE4").is_some() {
        return embree4();
    }

    let (include_dirs, lib_dirs) = search_dirs();
    // Only Embree 4 installed (Debian 13, Ubuntu 24.04): say which switch to use.
    let only_4 = |what: &str| {
        find_dir(&lib_dirs, "libembree4.so").map_or(String::new(), |d| {
            format!(
                " This system has Embree 4 ({}) but not {what}: build with `--features embree4`.",
                d.join("libembree4.so").display()
            )
        })
    };
    let Some(include_dir) = find_dir(&include_dirs, "embree3/rtcore.h") else {
        fail(&format!(
            "caustix needs Embree 3's headers (embree3/rtcore.h was not found in {include_dirs:?}); \
             {INSTALL_HINT}.{}",
            only_4("Embree 3's headers")
        ));
    };
    let Some(lib_dir) = find_dir(&lib_dirs, "libembree3.so") else {
        fail(&format!(
            "caustix needs Embree 3's library (libembree3.so was not found in {lib_dirs:?}); {INSTALL_HINT}.{}",
            only_4("Embree 3's library")
        ));
    };
    // bindgen loads libclang at run time and panics with a long message when it is absent.
    if !libclang_available() {
        fail(&format!(
            "caustix generates its Embree bindings with bindgen, which needs libclang; {INSTALL_HINT}"
        ));
    }

    link(&lib_dir, "embree3");

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
