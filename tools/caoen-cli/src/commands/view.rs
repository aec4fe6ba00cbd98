//! `caoen view`: the web viewer (`tools/web/`) and one `.cae` file served on
//! localhost by a small HTTP server, so the page can be opened without other tools. The
//! viewer's files are read from disk, not built in: its WebAssembly package is built
//! separately (`tools/web/build.sh`), and the folder is found by `--web`,
//! `$CAOEN_WEB_DIR` or the source tree this binary was built from.

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::cli::{GlobalArgs, ViewArgs};
use crate::failure::{CliError, CliResult};

/// The path the file is served at.
const FILE_PATH: &str = "/file.cae";

/// Serves the viewer and `a.input` until the process is stopped.
pub fn run(global: &GlobalArgs, a: &ViewArgs) -> CliResult {
    let web = web_dir(a.web.as_deref());
    let wasm = web.join("pkg").join("caoen_bg.wasm");
    if !wasm.is_file() {
        return Err(CliError::Failed(format!(
            "{}: the viewer's WebAssembly package is not built (run tools/web/build.sh, or give --web DIR)",
            wasm.display()
        )));
    }
    let len = std::fs::metadata(&a.input)
        .map_err(|e| CliError::io(&a.input, e))?
        .len();
    let file = std::fs::File::open(&a.input).map_err(|e| CliError::io(&a.input, e))?;
    let bytes = caoen::image_io::transcode::read_cae(file, Some(len), &global.limits)
        .map_err(|e| CliError::io(&a.input, e))?;
    let listener = TcpListener::bind(("127.0.0.1", a.port))
        .map_err(|e| CliError::Failed(format!("127.0.0.1:{}: {e}", a.port)))?;
    let port = listener
        .local_addr()
        .map_err(|e| CliError::Failed(e.to_string()))?
        .port();
    // The URL goes to stdout whatever --quiet says: it is the command's output.
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "http://127.0.0.1:{port}/index.html?src={FILE_PATH}");
    let _ = out.flush();
    drop(out);
    let site = Arc::new(Site { web, file: bytes });
    for stream in listener.incoming().flatten() {
        let site = Arc::clone(&site);
        std::thread::spawn(move || {
            // A client that goes away mid-answer is no concern of the server's.
            let _ = site.answer(stream);
        });
    }
    Ok(())
}

/// The viewer's folder: `dir`, else `$CAOEN_WEB_DIR`, else this source tree's.
fn web_dir(dir: Option<&Path>) -> PathBuf {
    dir.map(Path::to_path_buf)
        .or_else(|| std::env::var_os("CAOEN_WEB_DIR").map(PathBuf::from))
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/web"))
}

struct Site {
    web: PathBuf,
    file: Vec<u8>,
}

impl Site {
    fn answer(&self, stream: TcpStream) -> std::io::Result<()> {
        let mut reader = BufReader::new(stream.try_clone()?);
        let mut line = String::new();
        reader.read_line(&mut line)?;
        // The headers are read and ignored: every answer closes the connection.
        let mut header = String::new();
        while reader.read_line(&mut header)? > 2 {
            header.clear();
        }
        let mut parts = line.split_whitespace();
        let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
        let path = target.split(['?', '#']).next().unwrap_or("");
        let found = match (method, path) {
            ("GET", FILE_PATH) => Some((self.file.clone(), "application/octet-stream")),
            ("GET", "/") => self.static_file("index.html"),
            ("GET", p) => self.static_file(p.trim_start_matches('/')),
            _ => None,
        };
        let mut stream = stream;
        match found {
            Some((body, kind)) => {
                write!(
                    stream,
                    "HTTP/1.1 200 OK\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
                    body.len()
                )?;
                stream.write_all(&body)?;
            }
            None => {
                let body = b"not found\n";
                write!(
                    stream,
                    "HTTP/1.1 404 Not Found\r\nContent-Type: text/plain\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
                    body.len()
                )?;
                stream.write_all(body)?;
            }
        }
        stream.flush()
    }

    /// A file of the viewer's folder by its relative URL path: plain names only, so
    /// nothing outside the folder can be asked for.
    fn static_file(&self, rel: &str) -> Option<(Vec<u8>, &'static str)> {
        let plain = rel.split('/').all(|part| {
            !part.is_empty()
                && !part.starts_with('.')
                && part
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "._-".contains(c))
        });
        if !plain {
            return None;
        }
        let kind = match rel.rsplit('.').next()? {
            "html" => "text/html; charset=utf-8",
            "js" | "mjs" => "text/javascript; charset=utf-8",
            "css" => "text/css; charset=utf-8",
            "wasm" => "application/wasm",
            "png" => "image/png",
            "json" => "application/json",
            _ => return None,
        };
        let path = self.web.join(rel);
        path.is_file()
            .then(|| std::fs::read(&path).ok())
            .flatten()
            .map(|b| (b, kind))
    }
}
