//! The Python package (`tools/python`): built by maturin into a wheel, installed into a
//! virtual environment with NumPy, Pillow, pytest and Dask, and its pytest suite run
//! against the `caoen` binary of this build (`CAOEN_CLI`), for the same bytes as the
//! command line. Without Python 3 (with venv and pip) the test is skipped, saying so,
//! except under `CI=true`, where it fails.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The Python interpreter: `$PYTHON`, else `python3`.
fn python() -> String {
    std::env::var("PYTHON").unwrap_or_else(|_| "python3".into())
}

/// Runs `cmd`, failing the test with its output if it fails.
fn run(cmd: &mut Command, what: &str) -> Output {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot run: {e}"));
    assert!(
        out.status.success(),
        "{what} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The build's target folder (this test's temporary folder is `<target>/tmp`).
fn target_dir() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .expect("CARGO_TARGET_TMPDIR is inside the target folder")
        .to_path_buf()
}

#[test]
fn the_python_package_builds_installs_and_passes_its_tests() {
    let python = python();
    let usable = Command::new(&python)
        .args([
            "-c",
            "import venv, ensurepip, sys; assert sys.version_info >= (3, 9)",
        ])
        .output()
        .is_ok_and(|o| o.status.success());
    if !common::tool_present(usable, "Python 3.9+ with venv and pip") {
        return;
    }
    let root = common::repo_root();
    let target = target_dir();
    // Kept between runs: packages already installed are not downloaded again.
    let venv = target.join("python-venv");
    let bin = venv.join(if cfg!(windows) { "Scripts" } else { "bin" });
    let venv_python = bin.join(if cfg!(windows) {
        "python.exe"
    } else {
        "python"
    });
    if !venv_python.exists() {
        run(
            Command::new(&python).args(["-m", "venv"]).arg(&venv),
            "python -m venv",
        );
    }
    run(
        Command::new(&venv_python).args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "maturin>=1.9,<2",
            "numpy",
            "pillow",
            "pytest",
            "dask[distributed]",
        ]),
        "pip install maturin numpy pillow pytest dask[distributed]",
    );
    // A release build: the codec in a debug build makes the suite minutes slower than
    // the build saves. Its own folder, apart from the folders cargo is using.
    let wheels = target.join("python-wheels");
    let _ = std::fs::remove_dir_all(&wheels);
    run(
        Command::new(&venv_python)
            .args(["-m", "maturin", "build", "--release", "--quiet", "-o"])
            .arg(&wheels)
            .current_dir(root.join("tools/python"))
            .env("CARGO_TARGET_DIR", target.join("python")),
        "maturin build",
    );
    let wheel = std::fs::read_dir(&wheels)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "whl"))
        .expect("maturin wrote a wheel");
    run(
        Command::new(&venv_python)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
                "--force-reinstall",
                "--no-deps",
            ])
            .arg(&wheel),
        "pip install the wheel",
    );
    let out = run(
        Command::new(&venv_python)
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .arg(root.join("tools/python/tests"))
            .current_dir(root.join("tools/python/tests"))
            // No __pycache__ folders in the source tree.
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .env("CAOEN_CLI", env!("CARGO_BIN_EXE_caoen")),
        "pytest tools/python/tests",
    );
    let report = String::from_utf8_lossy(&out.stdout);
    println!("{report}");
    assert!(report.contains(" passed"), "{report}");
}
