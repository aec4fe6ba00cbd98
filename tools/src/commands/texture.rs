//! `caoen distort`: image distortion by moving control points (`docs/texture.md`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use caoen::codec::decoder;
use caoen::image_io;
use caoen::texture::warp::{self, Move, Warp};
use caoen::texture::TextureError;

use crate::cli::{DistortArgs, GlobalArgs};
use crate::commands::compare::is_cae;
use crate::commands::note;
use crate::failure::{CliError, CliResult};
use crate::output::Target;

/// Parses `x,y:x2,y2`.
pub fn parse_move(s: &str) -> CliResult<Move> {
    let bad = || CliError::Usage(format!("--move {s:?}: expected x,y:x2,y2 (pixels)"));
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let pt = |t: &str| -> CliResult<[f64; 2]> {
        let (x, y) = t.split_once(',').ok_or_else(bad)?;
        let x: f64 = x.trim().parse().map_err(|_| bad())?;
        let y: f64 = y.trim().parse().map_err(|_| bad())?;
        if x.is_finite() && y.is_finite() {
            Ok([x, y])
        } else {
            Err(bad())
        }
    };
    Ok(Move {
        from: pt(a)?,
        to: pt(b)?,
    })
}

#[derive(serde::Deserialize)]
#[serde(untagged)]
enum MoveJson {
    Object(Move),
    Pair([[f64; 2]; 2]),
}

/// Reads a moves JSON file.
pub fn read_moves(path: &Path) -> CliResult<Vec<Move>> {
    let text = std::fs::read_to_string(path).map_err(|e| CliError::io(path, e))?;
    let v: Vec<MoveJson> = serde_json::from_str(&text)
        .map_err(|e| CliError::Failed(format!("{}: {e}", path.display())))?;
    let moves: Vec<Move> = v
        .into_iter()
        .map(|m| match m {
            MoveJson::Object(m) => m,
            MoveJson::Pair([from, to]) => Move { from, to },
        })
        .collect();
    if moves
        .iter()
        .any(|m| !m.from.iter().chain(&m.to).all(|v| v.is_finite()))
    {
        return Err(CliError::Failed(format!(
            "{}: a move is not finite",
            path.display()
        )));
    }
    Ok(moves)
}

fn tex_err(e: TextureError) -> CliError {
    CliError::Failed(e.to_string())
}

/// `caoen distort`.
pub fn distort(global: &GlobalArgs, a: &DistortArgs) -> CliResult {
    let moves = match &a.moves_file {
        Some(p) => read_moves(p)?,
        None => a
            .moves
            .iter()
            .map(|s| parse_move(s))
            .collect::<CliResult<_>>()?,
    };
    if moves.is_empty() {
        return Err(CliError::Usage(
            "give at least one --move x,y:x2,y2 or --moves FILE".into(),
        ));
    }
    let fmt_for = |f| {
        if a.output.as_os_str() == "-" {
            Ok(image_io::OutputFormat::natural(f))
        } else {
            image_io::OutputFormat::for_path(&a.output, f).ok_or_else(|| {
                CliError::Usage(format!(
                    "{}: output must end in .png or .exr",
                    a.output.display()
                ))
            })
        }
    };
    let start = Instant::now();
    let (img, warp) = if is_cae(&a.input) {
        let bytes = std::fs::read(&a.input).map_err(|e| CliError::io(&a.input, e))?;
        let d = decoder::read(&bytes, caoen::codec::DEFAULT_MAX_PIXELS)
            .map_err(|e| CliError::Failed(format!("{}: {e}", a.input.display())))?;
        fmt_for(d.header.format)?;
        let warp = Warp::new(d.header.width, d.header.height, &moves).map_err(tex_err)?;
        check(global, &warp);
        (
            warp::warp_decoded(&d, &warp, a.supersample).map_err(tex_err)?,
            warp,
        )
    } else {
        let img = image_io::load(&a.input).map_err(|e| CliError::Failed(e.to_string()))?;
        fmt_for(img.format())?;
        let warp = Warp::new(img.width(), img.height(), &moves).map_err(tex_err)?;
        check(global, &warp);
        (
            warp::warp_raster(&img, &warp, a.supersample).map_err(tex_err)?,
            warp,
        )
    };
    let img = if a.grid {
        warp::draw_grid(img, &warp).map_err(tex_err)?
    } else {
        img
    };
    let bytes = image_io::encode(&img, fmt_for(img.format())?)
        .map_err(|e| CliError::Failed(format!("{}: {e}", a.output.display())))?;
    let target = Target::from_arg(Some(&a.output), PathBuf::new);
    target.write(&bytes, true)?;
    note(
        global,
        format!(
            "{} -> {}: {} moves, {} anchors, {}x{} in {:.3} s",
            a.input.display(),
            target.display(),
            warp.moves().len(),
            warp.anchors(),
            img.width(),
            img.height(),
            start.elapsed().as_secs_f64()
        ),
    );
    Ok(())
}

/// Warns (always, even with --quiet: it is about the result) on fold-over.
fn check(_global: &GlobalArgs, warp: &Warp) {
    let (w, h) = (warp.frame().width, warp.frame().height);
    let step = (w.max(h) as f64 / 128.0).max(1.0);
    let r = warp.check_folds(step);
    if !r.is_consistent() {
        eprintln!(
            "warning: inconsistent moves: the warp folds over at {} of {} sampled points \
             (min Jacobian determinant {:.3}); overlapping parts are averaged",
            r.folded, r.samples, r.min_det
        );
    }
}
