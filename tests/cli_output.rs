//! End-to-end tests of how every command writes its outputs: one overwrite rule
//! (`-f/--force`), never over an input, devices and FIFOs written in place, symbolic
//! links followed, no temporary file left behind, and stdout write errors reported.

mod common;
use common::{argv, assert_ok, caoen, caoen_ok, s, stderr};

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// Exit code 1 and a single `error:` line, no panic.
fn assert_fails(out: &Output, needle: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.starts_with("error: ") && err.lines().count() == 1,
        "{err}"
    );
    assert!(err.contains(needle), "{err}");
}

/// A fresh directory for the test `name`, with a small PNG and its `.cae` in it.
fn inputs(name: &str) -> (PathBuf, PathBuf, PathBuf) {
    let d = common::fresh_dir(&format!("cli-output-{name}"));
    let img = caoen_corpus::generate(caoen_corpus::Class::Scene, 48, 32, 1);
    let png = d.join("in.png");
    img.to_dynamic_image().save(&png).unwrap();
    let cae = d.join("in.cae");
    caoen_ok(&["encode", s(&png), "-o", s(&cae), "--quiet"]);
    (d, png, cae)
}

/// The file `name` in `d`, holding `old`: an output already there.
fn old_file(d: &Path, name: &str) -> PathBuf {
    let path = d.join(name);
    std::fs::write(&path, b"old").unwrap();
    path
}

/// No `.NAME.XXXXXX.caoen-tmp` file is left in `d`.
fn assert_no_temporaries(d: &Path) {
    let left: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".caoen-tmp") || n.ends_with(".partial"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

#[test]
fn an_existing_output_is_replaced_only_with_force() {
    let (d, png, cae) = inputs("force");
    let back = d.join("back.png");
    let model = d.join("ring.json");
    let mesh = d.join("ring.obj");
    let render = d.join("ring.png");
    // Every command that writes a file, once to create the output and once more.
    let runs: Vec<Vec<&str>> = vec![
        vec!["decode", s(&cae), "-o", s(&back)],
        vec!["encode", s(&png), "-o", s(&cae)],
        vec!["surface", "export", "builtin:ring", "-o", s(&model)],
        vec![
            "surface",
            "mesh",
            "builtin:ring",
            "-o",
            s(&mesh),
            "--detail",
            "1",
        ],
        vec![
            "surface",
            "render",
            "builtin:ring",
            "-o",
            s(&render),
            "--size",
            "16x12",
        ],
        vec!["distort", s(&png), "-o", s(&back), "--move", "4,4:6,5"],
    ];
    for args in &runs {
        let mut args = args.clone();
        args.push("--quiet");
        let target = PathBuf::from(args[args.iter().position(|a| *a == "-o").unwrap() + 1]);
        if !target.exists() {
            caoen_ok(&args);
        }
        let before = std::fs::read(&target).unwrap();
        let again = caoen(&args);
        assert_fails(&again, "exists; pass -f/--force to overwrite it");
        assert_eq!(std::fs::read(&target).unwrap(), before, "{args:?}");
        args.push("-f");
        caoen_ok(&args);
        args.pop();
        args.push("--force");
        caoen_ok(&args);
    }
    // A default-named output follows the same rule, and says how to name another.
    let default = d.join("in.cae");
    assert!(default.exists());
    let out = caoen(&["encode", s(&png), "--quiet"]);
    assert_fails(&out, "or -o to name the output");
    caoen_ok(&["encode", s(&png), "--quiet", "-f"]);
    assert_no_temporaries(&d);
}

#[test]
#[cfg(unix)]
fn a_replaced_file_keeps_its_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let (d, _, cae) = inputs("perms");
    let out = old_file(&d, "out.png");
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o640)).unwrap();
    caoen_ok(&["decode", s(&cae), "-o", s(&out), "-f", "--quiet"]);
    let meta = std::fs::metadata(&out).unwrap();
    assert_eq!(meta.permissions().mode() & 0o777, 0o640);
    assert!(std::fs::read(&out).unwrap().starts_with(b"\x89PNG"));
}

#[test]
fn an_input_is_never_overwritten_even_with_force() {
    let (d, png, cae) = inputs("input");
    let png_bytes = std::fs::read(&png).unwrap();
    let cae_bytes = std::fs::read(&cae).unwrap();
    let model = d.join("ring.json");
    caoen_ok(&["surface", "export", "builtin:ring", "-o", s(&model)]);
    // A caoen file under an image name, so that decoding it onto itself is no usage
    // error (the output's extension picks the format).
    let cae_png = d.join("cae.png");
    std::fs::copy(&cae, &cae_png).unwrap();
    let moves = d.join("moves.json");
    std::fs::write(&moves, "[[[4, 4], [6, 5]]]").unwrap();
    let runs: Vec<Vec<&str>> = vec![
        vec!["encode", s(&png), "-o", s(&png)],
        vec!["encode", s(&png), "-o", s(&cae), "--keypoint-map", s(&png)],
        vec!["decode", s(&cae_png), "-o", s(&cae_png)],
        vec!["distort", s(&png), "-o", s(&png), "--move", "4,4:6,5"],
        vec!["distort", s(&png), "-o", s(&moves), "--moves", s(&moves)],
        vec!["surface", "export", s(&model), "-o", s(&model)],
        vec![
            "surface",
            "render",
            "builtin:ring",
            "-o",
            s(&png),
            "--texture",
            s(&png),
        ],
    ];
    for args in &runs {
        let mut args = args.clone();
        args.push("-f");
        let out = caoen(&args);
        assert_fails(&out, "is an input of this command");
    }
    assert_eq!(std::fs::read(&png).unwrap(), png_bytes);
    assert_eq!(std::fs::read(&cae).unwrap(), cae_bytes);
    assert_eq!(std::fs::read(&cae_png).unwrap(), cae_bytes);
    // The same file under another name: a symbolic link or a hard link.
    #[cfg(unix)]
    {
        let link = d.join("link.png");
        std::os::unix::fs::symlink(&png, &link).unwrap();
        let out = caoen(&["encode", s(&link), "-o", s(&png), "-f"]);
        assert_fails(&out, "is an input of this command (as ");
        let out = caoen(&["encode", s(&png), "-o", s(&link), "-f"]);
        assert_fails(&out, "is an input of this command");
        let hard = d.join("hard.png");
        std::fs::hard_link(&png, &hard).unwrap();
        let out = caoen(&["encode", s(&hard), "-o", s(&png), "-f"]);
        assert_fails(&out, "is an input of this command");
        assert_eq!(std::fs::read(&png).unwrap(), png_bytes);
    }
    // Two outputs of one command may not be the same file either.
    let both = d.join("both.png");
    let out = caoen(&argv(
        "surface render builtin:ring -o @ --depth-out @",
        &[s(&both), s(&both)],
    ));
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("two outputs"), "{}", stderr(&out));
    assert!(!both.exists());
}

/// A character device that discards what is written to it: /dev/null, or /dev/zero
/// where /dev/null is not a device (some containers).
#[cfg(unix)]
fn discarding_device() -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    ["/dev/null", "/dev/zero"]
        .into_iter()
        .find(|p| std::fs::metadata(p).is_ok_and(|m| m.file_type().is_char_device()))
        .expect("a discarding character device")
}

#[test]
#[cfg(unix)]
fn devices_and_fifos_are_written_in_place() {
    use std::io::Read;
    use std::os::unix::fs::FileTypeExt;
    let (d, png, cae) = inputs("devices");
    // A device: written without --force, and still a device afterwards.
    let dev = discarding_device();
    caoen_ok(&["decode", s(&cae), "-o", dev, "--quiet"]);
    caoen_ok(&["encode", s(&png), "-o", dev, "--quiet"]);
    caoen_ok(&argv(
        "surface render builtin:ring -o @ --size 16x12 --quiet",
        &[dev],
    ));
    assert!(std::fs::metadata(dev).unwrap().file_type().is_char_device());
    // /dev/stdout is standard output, here a pipe, in the natural format.
    let out = caoen(&["decode", s(&cae), "-o", "/dev/stdout", "--quiet"]);
    assert_ok(&out);
    assert!(out.stdout.starts_with(b"\x89PNG"), "a PNG on stdout");
    // A FIFO, read by a thread: it gets the whole PNG and stays a FIFO.
    let fifo = d.join("pipe");
    let made = Command::new("mkfifo").arg(&fifo).status();
    if !common::tool_present(made.is_ok_and(|s| s.success()), "mkfifo") {
        return;
    }
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            std::fs::File::open(&fifo)
                .unwrap()
                .read_to_end(&mut bytes)
                .unwrap();
            bytes
        })
    };
    caoen_ok(&["decode", s(&cae), "-o", s(&fifo), "--quiet"]);
    let got = reader.join().unwrap();
    let want = caoen(&["decode", s(&cae), "-o", "-", "--quiet"]).stdout;
    assert_eq!(got, want);
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    assert_no_temporaries(&d);
}

#[test]
#[cfg(unix)]
fn a_symbolic_link_output_writes_the_file_it_points_at() {
    let (d, _, cae) = inputs("symlink");
    let sub = d.join("sub");
    std::fs::create_dir(&sub).unwrap();
    let real = old_file(&sub, "real.png");
    let link = d.join("link.png");
    std::os::unix::fs::symlink("sub/real.png", &link).unwrap();
    // The target exists: the rule asks for --force, then the target is replaced.
    assert_fails(
        &caoen(&["decode", s(&cae), "-o", s(&link), "--quiet"]),
        "exists",
    );
    caoen_ok(&["decode", s(&cae), "-o", s(&link), "-f", "--quiet"]);
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(
        std::fs::read_link(&link).unwrap(),
        Path::new("sub/real.png")
    );
    assert!(std::fs::read(&real).unwrap().starts_with(b"\x89PNG"));
    assert_no_temporaries(&d);
    assert_no_temporaries(&sub);
    // A link to nothing is refused, and nothing is created where it points.
    let dangling = d.join("dangling.png");
    std::os::unix::fs::symlink("missing.png", &dangling).unwrap();
    assert_fails(
        &caoen(&["decode", s(&cae), "-o", s(&dangling), "-f", "--quiet"]),
        "symbolic link to a missing file",
    );
    assert!(!d.join("missing.png").exists());
}

#[test]
fn directories_and_sockets_are_refused() {
    let (d, _, cae) = inputs("special");
    let dir = d.join("dir.png");
    std::fs::create_dir(&dir).unwrap();
    assert_fails(
        &caoen(&["decode", s(&cae), "-o", s(&dir), "-f"]),
        "is a directory",
    );
    assert!(dir.is_dir());
    #[cfg(unix)]
    {
        let sock = d.join("sock.png");
        let _listener = std::os::unix::net::UnixListener::bind(&sock).unwrap();
        assert_fails(
            &caoen(&["decode", s(&cae), "-o", s(&sock), "-f"]),
            "is a socket",
        );
    }
}

/// Runs caoen with a 512-byte file size limit, so that writing a file fails (EFBIG;
/// the shell ignores SIGXFSZ so that the write returns the error).
#[cfg(unix)]
fn caoen_with_small_file_limit(args: &[&str]) -> Output {
    let mut line = format!(
        "trap '' XFSZ; ulimit -f 1 && exec '{}'",
        env!("CARGO_BIN_EXE_caoen")
    );
    for a in args {
        line += &format!(" '{a}'");
    }
    Command::new("sh")
        .arg("-c")
        .arg(line)
        .output()
        .expect("run sh")
}

#[test]
#[cfg(unix)]
fn a_failed_write_leaves_no_temporary_and_keeps_the_old_file() {
    let (d, _, cae) = inputs("failed");
    let new = d.join("new.png");
    let old = old_file(&d, "old.png");
    for (target, force) in [(&new, false), (&old, true)] {
        let mut args = vec![
            "decode",
            s(&cae),
            "-o",
            s(target),
            "--size",
            "400x400",
            "--quiet",
        ];
        if force {
            args.push("-f");
        }
        let out = caoen_with_small_file_limit(&args);
        assert_fails(&out, target.file_name().unwrap().to_str().unwrap());
        assert!(!stderr(&out).contains("caoen-tmp"), "{}", stderr(&out));
    }
    assert!(!new.exists(), "no half-written output");
    assert_eq!(
        std::fs::read(&old).unwrap(),
        b"old",
        "the old file is intact"
    );
    assert_no_temporaries(&d);
}

#[test]
#[cfg(unix)]
fn a_stdout_write_error_fails_the_command() {
    let (_, _, cae) = inputs("stdout");
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full");
    if !common::tool_present(full.is_ok(), "/dev/full") {
        return;
    }
    let full = full.unwrap();
    for args in [
        vec!["decode", s(&cae), "-o", "-"],
        vec!["info", s(&cae)],
        vec!["info", s(&cae), "--json"],
        vec!["surface", "info", "builtin:blob"],
        vec!["surface", "eval", "builtin:blob", "--grid", "4x4"],
        vec!["surface", "export", "builtin:blob", "-o", "-"],
        vec!["compare", s(&cae), s(&cae)],
        vec!["corpus", "--list"],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_caoen"))
            .args(&args)
            .arg("--quiet")
            .stdout(Stdio::from(full.try_clone().unwrap()))
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.starts_with("error: standard output: ") && err.lines().count() == 1,
            "{args:?}: {err}"
        );
    }
}
